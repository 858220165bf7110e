#include "porta/slam/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <filesystem>
#include <system_error>

namespace porta::slam {

namespace {

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

bool write_all(int fd, std::span<const std::uint8_t> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

// The temporary is in the target's folder (rename is atomic only within one file system); its
// name is unique per process and call, and O_EXCL never reuses another writer's file.
void write_file_atomically(const std::string& path, std::span<const std::uint8_t> bytes) {
  static std::atomic<std::uint64_t> counter{0};
  std::string temporary;
  int fd = -1;
  for (int attempt = 0; fd < 0; ++attempt) {
    temporary = path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
    fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && (errno != EEXIST || attempt >= 100)) {
      throw AtomicWriteError("cannot write '" + path + "': cannot create the temporary file '" + temporary +
                             "': " + errno_text(errno));
    }
  }
  const auto give_up = [&](const std::string& step) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    ::unlink(temporary.c_str());
    throw AtomicWriteError("cannot write '" + path + "': " + step + " '" + temporary + "' failed: " +
                           errno_text(error) + " (the previous file, if any, is unchanged)");
  };
  if (!write_all(fd, bytes)) give_up("writing");
  if (::fsync(fd) != 0) give_up("fsync of");
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) give_up("closing");
  if (::rename(temporary.c_str(), path.c_str()) != 0) give_up("renaming over the target");
  // Make the rename itself durable; a folder that cannot be opened or synced leaves the file
  // complete either way, so this is best effort.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::filesystem::path folder = parent.empty() ? std::filesystem::path(".") : parent;
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void write_file_atomically(const std::string& path, std::string_view text) {
  write_file_atomically(path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

}  // namespace porta::slam
