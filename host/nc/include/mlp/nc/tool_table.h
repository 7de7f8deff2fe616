#pragma once
/// @file LinuxCNC's tool table file, read and written the way a shop expects: every line the
/// adapter does not change stays byte for byte (comments, pockets, order, blank lines, words it
/// does not own), and a change reaches the disk whole or not at all.
///
/// Line format (LinuxCNC docs, "Tool table format"): `T<tool> P<pocket> [X Y Z A B C U V W
/// <offset>] [D<diameter>] [I<front angle>] [J<back angle>] [Q<orientation>] [;comment]`, machine
/// units, D a diameter. T and P are required; a tool number appears once.

#include "mlp/base/input_error.h"
#include "mlp/nc/offsets.h"

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::nc {

/// A tool table that cannot be read, names the file and line; or an update that cannot apply.
class ToolTableError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct ToolRecord {
  int tool = 0, pocket = 0;
  std::map<char, double> words;  ///< X Y Z A B C U V W D I J Q present on the line
  std::string comment;           ///< after ';', without it
  /// A word's value; LinuxCNC reads an absent word as 0.
  double Get(char word) const;
  /// A register's value as the table holds it: a length is Z, a radius half of D, an offset
  /// its word (LinuxCNC has no wear registers: a wear register reads its geometry's word).
  double Register(ToolRegister reg) const;
};

class ToolTable {
 public:
  /// Throws ToolTableError naming `source` and the line.
  static ToolTable Parse(const std::string& text, const std::string& source);
  /// The file's text: untouched lines as read, changed lines rewritten.
  std::string Text() const;
  std::vector<ToolRecord> Tools() const;
  std::optional<ToolRecord> Find(int tool) const;
  /// Sets one word (X..W, D, I, J; Q must be 0..9 whole) of an existing tool, keeping its other
  /// words and comment; returns the value before. Throws ToolTableError for an unknown tool or
  /// word, or a value that is not finite.
  double Set(int tool, char word, double value);

 private:
  struct Word {
    char letter;
    std::string text;  ///< as in the file, e.g. "Z+12.5"
    double value;
  };
  struct Line {
    std::string original;
    std::optional<ToolRecord> record;
    std::vector<Word> words;
    std::string comment_text;  ///< from ';' to the end, as read
    bool changed = false;
  };
  static Line ParseLine(const std::string& text, const std::string& where);
  std::vector<Line> lines_;
};

/// Reads a tool table file; throws ToolTableError.
ToolTable LoadToolTable(const std::string& path);
/// Replaces the file atomically (temporary file in the same folder, fsync, rename, fsync of the
/// folder), keeping its permission bits. Throws ToolTableError; the old file is then untouched.
void SaveToolTable(const ToolTable& table, const std::string& path);

}  // namespace mlp::nc
