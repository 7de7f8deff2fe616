#pragma once
/// @file Whole files in and out. Every file the project writes (tool tables, NC snippets,
/// calibration records, probe models, clouds, pictures) is written whole or not at all: a
/// temporary file beside the target, fsync, rename (or a hard link, when an existing file must
/// never be replaced), fsync of the folder. A crash or a full disk leaves the old file or none,
/// never half of one; after a power cut the new file is there or the old one is.

#include <cstddef>
#include <functional>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <string_view>

namespace mlp::base {

/// A file could not be read or written; the message names the path and the reason.
class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// No limit on a file's size (ReadFile's default).
constexpr std::size_t kAnySize = static_cast<std::size_t>(-1);

/// The whole file as bytes; throws FileError when it cannot be opened or read, or holds more
/// than `max_bytes` (then after reading at most max_bytes + 1 of them: a 1 GiB sparse file
/// named as a manifest costs nothing).
std::string ReadFile(const std::string& path, std::size_t max_bytes = kAnySize);

/// ReadFile, its FileError raised as the caller's typed error (`prefix` + the reason): how a
/// module reads the files it owns.
template <class Error>
std::string ReadFileAs(const std::string& path,
                       const std::string& prefix = {},
                       std::size_t max_bytes = kAnySize) {
  try {
    return ReadFile(path, max_bytes);
  } catch (const FileError& e) {
    throw Error(prefix + e.what());
  }
}

enum class Replace {
  kAllowed,  ///< an existing file is replaced; its permission bits are kept
  kNever,    ///< an existing file is an error and stays as it was (records are never rewritten)
};

/// Writes `bytes` to `path` atomically (see the file comment). Throws FileError; the old file,
/// if any, is then untouched and no temporary file is left.
void WriteFileAtomically(const std::string& path,
                         std::string_view bytes,
                         Replace replace = Replace::kAllowed);

/// As above, for content produced by a stream writer (binary clouds, images).
void WriteFileAtomically(const std::string& path,
                         const std::function<void(std::ostream&)>& write,
                         Replace replace = Replace::kAllowed);

/// Appends one record (a line, its newline included) to a log such as an audit CSV: the file is
/// created with `header` first when it is absent or empty; the text goes out in one write() on
/// an O_APPEND descriptor, so records of concurrent writers never interleave (POSIX: the offset
/// and the write are one atomic step), then fsync: an appended record survives a power cut.
/// Throws FileError (a short write is an error; the log then ends in part of a line at most).
void AppendRecord(const std::string& path, std::string_view header, std::string_view line);

/// An exclusive advisory lock (flock(2)) on the file `path` (created, empty, when missing), held
/// while the object lives. flock locks belong to an open file description, so two threads of
/// one process exclude each other as two processes do: what a read-modify-write of a file that
/// two writers share (one tool table for two machines' lanes) needs around it. Waits up to
/// `wait_ms` for a holder, then throws FileError naming the file.
class FileLock {
 public:
  explicit FileLock(const std::string& path, int wait_ms = 10000);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

/// True for a temporary file a cut-short WriteFileAtomically leaves
/// (".<name>.mlp-tmp.<pid>.<n>", n counting the process's writes; ".<name>.mlp-tmp.<pid>"),
/// and for those of earlier versions (".<name>.mlp-tmp", "<cloud>.ply.tmp"): a service removes
/// them at start-up. Never true for a file the project writes.
bool IsTemporaryName(std::string_view filename);

}  // namespace mlp::base
