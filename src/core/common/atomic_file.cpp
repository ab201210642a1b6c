// Atomic file writes: see atomic_file.hpp.
#include "magnetometer_insitu_calibration/common/atomic_file.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <sys/stat.h>
#include <unistd.h>

namespace magnetometer_insitu_calibration {

namespace {

/// The directory part of `path` ("." without a slash, "/" for a file at the root).
std::string directory_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
}

/// The temporary file write_file_atomically writes first, beside `path`.
std::string temporary_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  return directory_of(path) + "/." + base + ".tmp." + std::to_string(::getpid());
}

}  // namespace

void prepare_file_directory(const std::string& path) {
  if (path.empty() || path.back() == '/') throw std::runtime_error("'" + path + "': not a file name");
  const std::string directory = directory_of(path);
  // Each missing ancestor in turn, from the root down; one that exists is left as it is.
  for (std::size_t next = directory.find('/', 1);; next = directory.find('/', next + 1)) {
    const std::string part = directory.substr(0, next);
    if (!part.empty() && ::mkdir(part.c_str(), 0755) != 0 && errno != EEXIST) {
      const std::string reason = std::strerror(errno);
      throw std::runtime_error(path + ": cannot create directory " + part + " (" + reason + ")");
    }
    if (next == std::string::npos) break;
  }
  struct stat info {};
  if (::stat(directory.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) {
    throw std::runtime_error(path + ": " + directory + " is not a directory");
  }
  const std::string temporary = temporary_of(path);
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    const std::string reason = std::strerror(errno);
    throw std::runtime_error(path + ": cannot create a file in " + directory + " (" + reason + ")");
  }
  ::close(fd);
  ::unlink(temporary.c_str());
}

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string directory = directory_of(path);
  const std::string temporary = temporary_of(path);
  auto fail = [&](const std::string& what) -> void {
    const std::string reason = std::strerror(errno);
    ::unlink(temporary.c_str());
    throw std::runtime_error(path + ": " + what + " (" + reason + ")");
  };
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    const std::string reason = std::strerror(errno);
    throw std::runtime_error(path + ": cannot create temporary file " + temporary + " (" + reason + ")");
  }
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(fd);
      fail("write failed");
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("fsync failed");
  }
  if (::close(fd) != 0) fail("close failed");
  if (::rename(temporary.c_str(), path.c_str()) != 0) fail("rename failed");
  // Make the rename itself durable (best effort: some file systems refuse fsync on directories).
  const int dir_fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
}

}  // namespace magnetometer_insitu_calibration
