// The directory backend of UploadStore and what both backends share (server/upload_store.h).
#include "server/upload_store.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <vector>

#include "server/session_cache.h"

namespace featureline::server {

bool is_mesh_id(std::string_view id) {
  return id.size() == 32 && id.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

std::string upload_meta_json(const StoredUpload& upload) {
  return nlohmann::json{{"format", to_string(upload.format)},
                        {"uploaded_at", upload.uploaded_at_unix_s},
                        {"bytes", upload.bytes.size()}}
      .dump();
}

std::size_t parse_upload_meta(std::string_view meta, const std::string& id, StoredUpload& upload) {
  const auto damaged = [&] { return StoreUnavailableError("the stored upload of mesh " + id + " is damaged (bad header)"); };
  const auto j = nlohmann::json::parse(meta, nullptr, false);
  if (!j.is_object() || !j.contains("format") || !j["format"].is_string() || !j.contains("bytes") ||
      !j["bytes"].is_number_unsigned() || !j.contains("uploaded_at") || !j["uploaded_at"].is_number_integer())
    throw damaged();
  const auto format = parse_mesh_format(j["format"].get<std::string>());
  if (!format) throw damaged();
  upload.format = *format;
  upload.uploaded_at_unix_s = j["uploaded_at"].get<std::int64_t>();
  return j["bytes"].get<std::size_t>();
}

namespace {

using SystemClock = std::chrono::system_clock;

std::string errno_text(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

// A full disk or quota is "full" (503, try later, nothing stored); anything else is "unavailable".
[[noreturn]] void throw_write_error(const std::string& what, const std::string& path) {
  if (errno == ENOSPC || errno == EDQUOT) throw StoreFullError("the upload store is out of space: " + errno_text(what, path));
  throw StoreUnavailableError("the upload store failed: " + errno_text(what, path));
}

void make_folder(const std::string& path) {
  if (mkdir(path.c_str(), 0700) != 0 && errno != EEXIST)
    throw StoreUnavailableError("cannot create the upload store folder: " + errno_text("mkdir", path));
  struct stat st{};
  if (stat(path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw StoreUnavailableError("the upload store path " + path + " is not a folder");
}

// Names in a folder (no "." or "..").
std::vector<std::string> list_folder(const std::string& path) {
  std::vector<std::string> names;
  DIR* dir = opendir(path.c_str());
  if (dir == nullptr) throw StoreUnavailableError("cannot list the upload store: " + errno_text("opendir", path));
  while (const dirent* entry = readdir(dir)) {
    const std::string name = entry->d_name;
    if (name != "." && name != "..") names.push_back(name);
  }
  closedir(dir);
  return names;
}

// Writes every byte of the iovecs (write may be partial).
bool write_all(int fd, iovec* parts, int count) {
  while (count > 0) {
    const ssize_t n = writev(fd, parts, count);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    std::size_t left = std::size_t(n);
    while (count > 0 && left >= parts->iov_len) left -= parts->iov_len, ++parts, --count;
    if (count > 0) parts->iov_base = static_cast<char*>(parts->iov_base) + left, parts->iov_len -= left;
  }
  return true;
}

bool read_whole_file(const std::string& path, std::string& out) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st{};
  if (fstat(fd, &st) != 0) return close(fd), false;
  out.resize(std::size_t(st.st_size));
  std::size_t got = 0;
  while (got < out.size()) {
    const ssize_t n = read(fd, out.data() + got, out.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += std::size_t(n);
  }
  close(fd);
  out.resize(got);
  return true;
}

class DirectoryStore final : public UploadStore {
 public:
  DirectoryStore(std::string root, StoreOptions options) : root_(std::move(root)), options_(std::move(options)) {
    make_folder(root_);
    make_folder(root_ + "/uploads");
    make_folder(root_ + "/gone");
    make_folder(root_ + "/tmp");
    // Writes a crash interrupted never became visible: drop them.
    for (const auto& name : list_folder(root_ + "/tmp")) unlink((root_ + "/tmp/" + name).c_str());
    for (const auto& name : list_folder(root_ + "/uploads")) {
      struct stat st{};
      if (is_mesh_id(name) && stat(upload_path(name).c_str(), &st) == 0) bytes_ += std::size_t(st.st_size);
    }
  }

  void put(const std::string& id, const StoredUpload& upload) override {
    if (!is_mesh_id(id)) throw std::invalid_argument("not a mesh id: " + id);
    const std::string header = upload_meta_json(upload) + "\n";
    const std::size_t size = header.size() + upload.bytes.size();
    reserve(size);
    try {
      write_atomically(id, header, upload.bytes);
    } catch (...) {
      release(size);
      throw;
    }
  }

  StoreLookup get(const std::string& id) override {
    StoreLookup found;
    std::string file;
    if (!is_mesh_id(id) || !read_whole_file(upload_path(id), file)) {
      // A missing file is a missing upload only while the folder itself is there.
      if (is_mesh_id(id) && (errno != ENOENT || access((root_ + "/uploads").c_str(), F_OK) != 0))
        throw StoreUnavailableError("the upload store failed: " + errno_text("open", upload_path(id)));
      found.why = tombstone(id);
      return found;
    }
    const auto newline = file.find('\n');
    if (newline == std::string::npos) throw StoreUnavailableError("the stored upload of mesh " + id + " is damaged (no header)");
    StoredUpload upload;
    const std::size_t length = parse_upload_meta(std::string_view(file).substr(0, newline), id, upload);
    if (file.size() - newline - 1 != length)
      throw StoreUnavailableError("the stored upload of mesh " + id + " is damaged (" + std::to_string(file.size() - newline - 1) +
                                  " bytes instead of " + std::to_string(length) + ")");
    file.erase(0, newline + 1);  // in place: a 256 MB upload is not copied again
    upload.bytes = std::move(file);
    found.upload = std::move(upload);
    return found;
  }

  bool touch(const std::string& id) override { return is_mesh_id(id) && set_mtime(upload_path(id), options_.now()); }

  bool erase(const std::string& id) override {
    if (!is_mesh_id(id)) return false;
    const bool removed = remove_upload(id);
    if (removed) write_tombstone(id, StoreMiss::deleted);
    return removed;
  }

  std::size_t expire_idle() override {
    const auto now = options_.now();
    std::size_t expired = 0;
    for (const auto& name : list_folder(root_ + "/uploads")) {
      if (is_mesh_id(name) && older_than(upload_path(name), now - options_.idle_ttl) && remove_upload(name)) {
        write_tombstone(name, StoreMiss::expired);
        ++expired;
      }
    }
    for (const auto& name : list_folder(root_ + "/gone"))
      if (older_than(root_ + "/gone/" + name, now - options_.tombstone_ttl)) unlink((root_ + "/gone/" + name).c_str());
    return expired;
  }

  std::size_t bytes() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return bytes_;
  }

  void probe() override {
    if (access((root_ + "/uploads").c_str(), W_OK) != 0)
      throw StoreUnavailableError("the upload store failed: " + errno_text("access", root_ + "/uploads"));
  }
  // A folder that vanished is unavailable (503), never taken for an empty store: nothing is lost unseen.
  StoreLosses losses() const override { return {}; }

  bool shared() const override { return false; }  // one server per folder
  std::string describe() const override { return "directory " + root_; }

 private:
  std::string upload_path(const std::string& id) const { return root_ + "/uploads/" + id; }
  std::string tombstone_path(const std::string& id, StoreMiss why) const {
    return root_ + "/gone/" + id + (why == StoreMiss::deleted ? ".deleted" : ".expired");
  }

  void reserve(std::size_t size) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (options_.max_bytes != 0 && bytes_ + size > options_.max_bytes)
      throw StoreFullError("the upload store holds " + std::to_string(bytes_ >> 20) + " MiB of its " +
                           std::to_string(options_.max_bytes >> 20) + " MiB; this upload needs " + std::to_string((size + (1 << 20) - 1) >> 20) +
                           " MiB more");
    bytes_ += size;
  }
  void release(std::size_t size) {
    std::lock_guard<std::mutex> lock(mutex_);
    bytes_ -= std::min(bytes_, size);
  }

  // temp file + fsync + rename + fsync of the folder: the upload is either wholly there or not.
  void write_atomically(const std::string& id, const std::string& header, const std::string& bytes) {
    const std::string temp = root_ + "/tmp/" + id + "." + random_session_id().substr(0, 8);
    const int fd = open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) throw_write_error("create", temp);
    iovec parts[2] = {{const_cast<char*>(header.data()), header.size()}, {const_cast<char*>(bytes.data()), bytes.size()}};
    if (!write_all(fd, parts, 2) || fsync(fd) != 0) {
      const int saved = errno;
      close(fd);
      unlink(temp.c_str());
      errno = saved;
      throw_write_error("write", temp);
    }
    close(fd);
    if (rename(temp.c_str(), upload_path(id).c_str()) != 0) {
      const int saved = errno;
      unlink(temp.c_str());
      errno = saved;
      throw_write_error("rename", temp);
    }
    sync_folder(root_ + "/uploads");
    set_mtime(upload_path(id), options_.now());  // the idle clock follows the injectable clock
  }

  static void sync_folder(const std::string& path) {
    const int fd = open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) throw_write_error("open", path);
    const int rc = fsync(fd);
    close(fd);
    if (rc != 0) throw_write_error("fsync", path);
  }

  // False when the file does not exist.
  static bool set_mtime(const std::string& path, SystemClock::time_point when) {
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(when.time_since_epoch()).count();
    const timespec t{time_t(ns / 1000000000), long(ns % 1000000000)};
    const timespec times[2] = {t, t};
    if (utimensat(AT_FDCWD, path.c_str(), times, 0) == 0) return true;
    if (errno == ENOENT) return false;
    throw StoreUnavailableError("the upload store failed: " + errno_text("utimensat", path));
  }

  static bool older_than(const std::string& path, SystemClock::time_point limit) {
    struct stat st{};
    if (stat(path.c_str(), &st) != 0) return false;
    const auto mtime = SystemClock::time_point(std::chrono::duration_cast<SystemClock::duration>(
        std::chrono::seconds(st.st_mtim.tv_sec) + std::chrono::nanoseconds(st.st_mtim.tv_nsec)));
    return mtime < limit;
  }

  bool remove_upload(const std::string& id) {
    struct stat st{};
    if (stat(upload_path(id).c_str(), &st) != 0) {
      // Not there is "not stored" only while the folder itself is there (as in get).
      if (errno != ENOENT || access((root_ + "/uploads").c_str(), F_OK) != 0)
        throw StoreUnavailableError("the upload store failed: " + errno_text("stat", upload_path(id)));
      return false;
    }
    if (unlink(upload_path(id).c_str()) != 0) {
      if (errno == ENOENT) return false;  // removed meanwhile by another request
      throw StoreUnavailableError("the upload store failed: " + errno_text("unlink", upload_path(id)));
    }
    release(std::size_t(st.st_size));
    return true;
  }

  void write_tombstone(const std::string& id, StoreMiss why) {
    const int fd = open(tombstone_path(id, why).c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd >= 0) close(fd);
    set_mtime(tombstone_path(id, why), options_.now());
  }

  StoreMiss tombstone(const std::string& id) const {
    if (!is_mesh_id(id)) return StoreMiss::unknown;
    if (access(tombstone_path(id, StoreMiss::deleted).c_str(), F_OK) == 0) return StoreMiss::deleted;
    if (access(tombstone_path(id, StoreMiss::expired).c_str(), F_OK) == 0) return StoreMiss::expired;
    return StoreMiss::unknown;
  }

  const std::string root_;
  const StoreOptions options_;
  mutable std::mutex mutex_;  // guards bytes_ (files are written atomically, no lock needed)
  std::size_t bytes_ = 0;
};

}  // namespace

std::unique_ptr<UploadStore> open_directory_store(const std::string& path, StoreOptions options) {
  if (path.empty()) throw std::invalid_argument("the upload store folder is empty");
  return std::make_unique<DirectoryStore>(path, std::move(options));
}

namespace {

const std::string kRedisScheme = "redis://";

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX sequences to their bytes; `what` names the part in the error (never its text: a password).
std::string percent_decoded(const std::string& text, const std::string& what, const std::string& shown_url) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      out += text[i];
      continue;
    }
    const int high = i + 2 < text.size() ? hex_digit(text[i + 1]) : -1;
    const int low = high < 0 ? -1 : hex_digit(text[i + 2]);
    if (low < 0)
      throw std::invalid_argument("the " + what + " in the Redis URL " + shown_url +
                                  " has a % not followed by two hex digits (write a literal % as %25)");
    out += char(high * 16 + low);
    i += 2;
  }
  return out;
}

// USER, USER:PASSWORD or :PASSWORD (a URL's userinfo).
void read_credentials(const std::string& userinfo, const std::string& shown_url, RedisAddress& address) {
  const auto colon = userinfo.find(':');
  address.user = percent_decoded(userinfo.substr(0, colon), "user", shown_url);
  if (colon != std::string::npos) address.password = percent_decoded(userinfo.substr(colon + 1), "password", shown_url);
}

// HOST[:PORT][/DB]
void read_location(std::string rest, const std::string& shown_url, RedisAddress& address) {
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    const std::string db = rest.substr(slash + 1);
    if (db.empty() || db.size() > 2 || db.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("the Redis database in " + shown_url + " must be a number 0-99");
    address.db = std::stoi(db);
    rest.erase(slash);
  }
  if (const auto colon = rest.rfind(':'); colon != std::string::npos) {
    const std::string port = rest.substr(colon + 1);
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) > 65535)
      throw std::invalid_argument("the Redis port in " + shown_url + " must be a number 1-65535");
    address.port = std::stoi(port);
    rest.erase(colon);
  }
  if (rest.empty()) throw std::invalid_argument("the Redis URL " + shown_url + " names no host (redis://HOST:PORT[/DB])");
  address.host = rest;
}

}  // namespace

std::string redacted_store_url(const std::string& url) {
  const auto at = url.rfind('@');
  if (url.rfind(kRedisScheme, 0) != 0 || at == std::string::npos) return url;
  return kRedisScheme + "***" + url.substr(at);
}

RedisAddress parse_redis_url(const std::string& url) {
  const std::string shown = redacted_store_url(url);
  if (url.rfind(kRedisScheme, 0) != 0) throw std::invalid_argument("not a redis:// URL: " + shown);
  RedisAddress address;
  std::string rest = url.substr(kRedisScheme.size());
  // The last @: a password may hold an unencoded @ or /, a host, port or database never does.
  if (const auto at = rest.rfind('@'); at != std::string::npos) {
    read_credentials(rest.substr(0, at), shown, address);
    rest.erase(0, at + 1);
  }
  read_location(rest, shown, address);
  return address;
}

std::unique_ptr<UploadStore> open_upload_store(const std::string& url, StoreOptions options, const std::string& password) {
  if (url.rfind(kRedisScheme, 0) != 0) return open_directory_store(url.rfind("dir:", 0) == 0 ? url.substr(4) : url, std::move(options));
  RedisAddress address = parse_redis_url(url);
  if (address.password.empty()) address.password = password;  // the URL's, when it has one, comes first
  if (!address.user.empty() && address.password.empty())
    throw std::invalid_argument("the Redis URL " + redacted_store_url(url) +
                                " names a user but no password: give it as redis://USER:PASSWORD@HOST or in " + kRedisPasswordVariable);
  return open_redis_store(address, std::move(options));
}

}  // namespace featureline::server
