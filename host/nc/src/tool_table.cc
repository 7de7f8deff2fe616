#include "mlp/nc/tool_table.h"

#include "mlp/base/files.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mlp::nc {
namespace {

namespace fs = std::filesystem;
constexpr const char* kValueWords = "XYZABCUVWDIJQ";
// Tool and pocket numbers LinuxCNC accepts (its tool numbers are int; pockets index the table).
constexpr int kMaxToolNumber = 99999;

[[noreturn]] void Fail(const std::string& what) { throw ToolTableError(what); }

std::string FormatValue(char word, double v) {
  if (word == 'Q') return std::to_string(static_cast<int>(v));
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  std::string s = buf;  // trailing zeros off, at least one decimal: "12.5", "0.0"
  while (s.size() > 2 && s.back() == '0' && s[s.size() - 2] != '.') s.pop_back();
  return s == "-0.0" ? "0.0" : s;
}

void CheckValue(char word, double v, const std::string& where) {
  if (!std::isfinite(v)) Fail(where + ": " + word + " must be a finite number");
  if (word == 'Q' && (v != std::floor(v) || v < 0 || v > 9))
    Fail(where + ": Q (orientation) must be a whole number 0..9");
  if (word == 'D' && v < 0) Fail(where + ": D (diameter) must not be negative");
}

}  // namespace

double ToolRecord::Get(char word) const {
  const auto it = words.find(word);
  return it == words.end() ? 0.0 : it->second;
}

double ToolRecord::Register(ToolRegister reg) const {
  if (const char word = OffsetWord(reg); word != 0) return Get(word);
  const bool length = reg == ToolRegister::kLengthGeometry || reg == ToolRegister::kLengthWear;
  return length ? Get('Z') : Get('D') / 2.0;
}

ToolTable::Line ToolTable::ParseLine(const std::string& text, const std::string& where) {
  Line line;
  line.original = text;
  const size_t semi = text.find(';');
  const std::string body = text.substr(0, semi);
  if (semi != std::string::npos) line.comment_text = text.substr(semi);
  std::istringstream in(body);
  std::string token;
  ToolRecord r;
  std::set<char> seen;
  bool has_t = false, has_p = false;
  while (in >> token) {
    const char letter = static_cast<char>(std::toupper(static_cast<unsigned char>(token[0])));
    const std::string number = token.substr(1);
    char* end = nullptr;
    const double v = number.empty() ? NAN : std::strtod(number.c_str(), &end);
    // NOLINTBEGIN(performance-inefficient-string-concatenation): messages of errors, built once
    if (number.empty() || end != number.c_str() + number.size())
      Fail(where + ": '" + token + "' is not a letter followed by a number");
    if (!seen.insert(letter).second) Fail(where + ": " + letter + " appears twice");
    if (letter == 'T' || letter == 'P') {
      if (v != std::floor(v) || v < 0 || v > kMaxToolNumber)
        Fail(where + ": " + letter + " must be a whole number 0.." +
             std::to_string(kMaxToolNumber));
      (letter == 'T' ? r.tool : r.pocket) = static_cast<int>(v);
      (letter == 'T' ? has_t : has_p) = true;
    } else if (std::strchr(kValueWords, letter) != nullptr) {
      CheckValue(letter, v, where);
      r.words[letter] = v;
    } else {
      Fail(where + ": unknown word '" + token + "' (T P X Y Z A B C U V W D I J Q)");
    }
    // NOLINTEND(performance-inefficient-string-concatenation)
    line.words.push_back({letter, token, v});
  }
  if (line.words.empty()) return line;  // blank or comment-only line
  if (!has_t || !has_p) Fail(where + ": a tool line needs T and P");
  if (semi != std::string::npos) r.comment = text.substr(semi + 1);
  line.record = r;
  return line;
}

ToolTable ToolTable::Parse(const std::string& text, const std::string& source) {
  ToolTable t;
  std::istringstream in(text);
  std::string raw;
  std::set<int> tools;
  int n = 0;
  while (std::getline(in, raw)) {
    ++n;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    Line line = ParseLine(raw, source + " line " + std::to_string(n));
    if (line.record && !tools.insert(line.record->tool).second)
      Fail(source + " line " + std::to_string(n) + ": tool T" + std::to_string(line.record->tool) +
           " is listed twice");
    t.lines_.push_back(std::move(line));
  }
  return t;
}

std::string ToolTable::Text() const {
  std::string out;
  for (const Line& l : lines_) {
    if (!l.changed) {
      out += l.original + "\n";
      continue;
    }
    std::string s;
    for (const Word& w : l.words) s += (s.empty() ? "" : " ") + w.text;
    if (!l.comment_text.empty()) s += " " + l.comment_text;
    out += s + "\n";
  }
  return out;
}

std::vector<ToolRecord> ToolTable::Tools() const {
  std::vector<ToolRecord> out;
  for (const Line& l : lines_)
    if (l.record) out.push_back(*l.record);
  return out;
}

std::optional<ToolRecord> ToolTable::Find(int tool) const {
  for (const Line& l : lines_)
    if (l.record && l.record->tool == tool) return l.record;
  return std::nullopt;
}

double ToolTable::Set(int tool, char word, double value) {
  word = static_cast<char>(std::toupper(static_cast<unsigned char>(word)));
  if (std::strchr(kValueWords, word) == nullptr || word == '\0')
    Fail(std::string("'") + word + "' is not a tool table value word (X..W, D, I, J, Q)");
  std::ostringstream where_text;  // (ostringstream: GCC 12's -Wrestrict false positive)
  where_text << "T" << tool << " " << word;
  const std::string where = where_text.str();
  CheckValue(word, value, where);
  for (Line& l : lines_) {
    if (!l.record || l.record->tool != tool) continue;
    const double before = l.record->Get(word);
    l.record->words[word] = value;
    const std::string text = std::string(1, word) + FormatValue(word, value);
    auto it = std::find_if(l.words.begin(), l.words.end(),
                           [&](const Word& w) { return w.letter == word; });
    if (it != l.words.end())
      *it = {word, text, value};
    else
      l.words.push_back({word, text, value});
    l.changed = true;
    return before;
  }
  Fail("tool T" + std::to_string(tool) + " is not in the tool table");
}

ToolTable LoadToolTable(const std::string& path) {
  std::string text;
  try {
    text = base::ReadFile(path);
  } catch (const base::FileError& e) {
    Fail(std::string("cannot read the tool table: ") + e.what());
  }
  return ToolTable::Parse(text, path);
}

void SaveToolTable(const ToolTable& table, const std::string& path) {
  try {
    base::WriteFileAtomically(path, table.Text());
  } catch (const base::FileError& e) {
    Fail(std::string("tool table not written: ") + e.what());
  }
}

}  // namespace mlp::nc
