#include "mlp/base/files.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mlp::base {
namespace {

namespace fs = std::filesystem;

std::string Why() { return std::strerror(errno); }

// POSIX gives no other way to make a file's data and its directory entry durable; the C++
// library has none (std::filesystem has no fsync).
bool Sync(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

constexpr std::string_view kTempMark = ".mlp-tmp";

// A hidden name beside the target, unique per write: the process id and a count of the
// process's writes. Unique per process only, two lanes of one host writing one tool table
// shared a temporary, and one lane's rename took the other's file away (8 of 160 writes lost,
// issue 48).
std::string TempPathFor(const fs::path& target) {
  static std::atomic<unsigned long> writes{0};
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string name(1, '.');  // appended piece by piece: GCC 12 -O3 false -Wrestrict on a + b
  name.append(target.filename().string()).append(kTempMark);
  name.append(1, '.').append(std::to_string(::getpid()));
  name.append(1, '.').append(std::to_string(writes.fetch_add(1)));
  return (dir / name).string();
}

[[noreturn]] void Abandon(const std::string& tmp, const std::string& why) {
  std::error_code ignored;
  fs::remove(tmp, ignored);
  throw FileError(why);
}

void Publish(const std::string& tmp, const std::string& path, Replace replace) {
  if (replace == Replace::kAllowed) {
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      Abandon(tmp, "cannot replace " + path + ": " + Why());
    return;
  }
  // link() fails when the name exists: a file is never replaced, even by a racing writer.
  if (::link(tmp.c_str(), path.c_str()) != 0) Abandon(tmp, "cannot create " + path + ": " + Why());
  std::error_code ignored;
  fs::remove(tmp, ignored);
}

}  // namespace

std::string ReadFile(const std::string& path, std::size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot read " + path + ": " + Why());
  if (max_bytes == kAnySize) {
    std::ostringstream bytes;
    bytes << in.rdbuf();
    if (in.bad()) throw FileError("cannot read " + path + ": " + Why());
    return std::move(bytes).str();
  }
  // In chunks, never more than one past the limit: the size a file claims (a FIFO has none, a
  // sparse file a false one) is not trusted.
  constexpr std::size_t kChunk = std::size_t{64} * 1024;
  std::string bytes;
  char chunk[kChunk];
  while (in && bytes.size() <= max_bytes) {
    in.read(chunk, static_cast<std::streamsize>(std::min(kChunk, max_bytes + 1 - bytes.size())));
    bytes.append(chunk, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw FileError("cannot read " + path + ": " + Why());
  if (bytes.size() > max_bytes)
    throw FileError(path + " holds more than " + std::to_string(max_bytes) + " bytes");
  return bytes;
}

bool IsTemporaryName(std::string_view name) {
  if (name.ends_with(".ply.tmp")) return true;
  if (name.size() <= kTempMark.size() + 1 || name[0] != '.') return false;
  const std::size_t mark = name.rfind(kTempMark);
  if (mark == std::string_view::npos) return false;
  // "", ".<pid>" (earlier versions) or ".<pid>.<n>".
  const std::string_view tail = name.substr(mark + kTempMark.size());
  const auto digits = [](std::string_view d) {
    return !d.empty() && d.find_first_not_of("0123456789") == std::string_view::npos;
  };
  if (tail.empty()) return true;
  if (tail[0] != '.') return false;
  const std::string_view rest = tail.substr(1);
  const std::size_t dot = rest.find('.');
  return dot == std::string_view::npos
             ? digits(rest)
             : digits(rest.substr(0, dot)) && digits(rest.substr(dot + 1));
}

void WriteFileAtomically(const std::string& path,
                         const std::function<void(std::ostream&)>& write,
                         Replace replace) {
  const fs::path target(path);
  const std::string tmp = TempPathFor(target);
  struct stat before {};
  const bool existed = ::stat(path.c_str(), &before) == 0;
  {
    std::ofstream out(tmp, std::ios::trunc | std::ios::binary);
    if (!out) throw FileError("cannot write " + tmp + ": " + Why());
    try {
      write(out);
    } catch (...) {  // the caller's writer gave up: its error, and no temporary left
      out.close();
      std::error_code ignored;
      fs::remove(tmp, ignored);
      throw;
    }
    out.flush();
    if (!out) Abandon(tmp, "cannot write " + tmp + " (disk full?)");
  }
  if (existed && replace == Replace::kAllowed) ::chmod(tmp.c_str(), before.st_mode & 07777);
  if (!Sync(tmp, O_RDONLY)) Abandon(tmp, "cannot sync " + tmp + ": " + Why());
  Publish(tmp, path, replace);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!Sync(dir.string(), O_RDONLY | O_DIRECTORY))
    throw FileError("cannot sync the folder " + dir.string() + ": " + Why());
}

FileLock::FileLock(const std::string& path, int wait_ms) {
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd_ < 0) throw FileError("cannot open the lock file " + path + ": " + Why());
  for (int waited_ms = 0; ::flock(fd_, LOCK_EX | LOCK_NB) != 0; waited_ms += 5) {
    if (errno != EWOULDBLOCK || waited_ms >= wait_ms) {
      const bool held = errno == EWOULDBLOCK;
      std::string why = held ? std::string("held by another writer for over ") : Why();
      if (held) why.append(std::to_string(wait_ms)).append(" ms");
      ::close(fd_);
      throw FileError(std::string("cannot lock ").append(path).append(": ").append(why));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

FileLock::~FileLock() { ::close(fd_); }  // closing the last descriptor releases the lock

void AppendRecord(const std::string& path, std::string_view header, std::string_view line) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw FileError("cannot append to " + path + ": " + Why());
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw FileError("cannot append to " + path + ": " + Why());
  std::string text;
  if (st.st_size == 0) text.append(header);
  text.append(line);
  const ssize_t written = ::write(fd, text.data(), text.size());
  if (written != static_cast<ssize_t>(text.size()))
    throw FileError("cannot append to " + path + ": " + (written < 0 ? Why() : "disk full?"));
  if (::fsync(fd) != 0) throw FileError("cannot sync " + path + ": " + Why());
}

void WriteFileAtomically(const std::string& path, std::string_view bytes, Replace replace) {
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      },
      replace);
}

}  // namespace mlp::base
