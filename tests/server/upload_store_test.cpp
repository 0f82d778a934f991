// The upload store (sessions that survive restarts and replicas): the directory backend, the Redis backend against a real
// redis-server started here on a free loopback port (also with requirepass and an ACL user),
// the store URL and its credentials, and DurableSessions (rebuild on a miss, restarts, single
// flight, what a 404 says, nothing kept when the store refuses).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "engine/errors.h"
#include "engine/prepared_mesh.h"
#include "server/session_cache.h"
#include "server/store_breaker.h"
#include "server/upload_store.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline::server {
namespace {

namespace fs = std::filesystem;
using SystemClock = std::chrono::system_clock;

// A fresh folder under the system's temporary folder, removed afterwards.
struct TempFolder {
  fs::path path;
  TempFolder() {
    char pattern[] = "/tmp/upload_store_test.XXXXXX";
    path = mkdtemp(pattern);
  }
  ~TempFolder() { fs::remove_all(path); }
};

StoredUpload upload_of(std::string bytes, MeshFormat format = MeshFormat::off) {
  StoredUpload u;
  u.bytes = std::move(bytes);
  u.format = format;
  u.uploaded_at_unix_s = 1764576000;
  return u;
}

// Bytes no text-based encoding would survive unchanged: NULs, newlines, high bytes.
std::string binary_bytes(std::size_t n) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = char((i * 131 + 7) & 0xFF);
  return s;
}

struct FakeWallClock {
  SystemClock::time_point now = SystemClock::time_point(std::chrono::seconds(1764576000));
  std::function<SystemClock::time_point()> fn() {
    return [this] { return now; };
  }
};

const std::string kId = "0123456789abcdef0123456789abcdef";
const std::string kOtherId = "fedcba9876543210fedcba9876543210";

// ---- directory ------------------------------------------------------------------------------

TEST(DirectoryStore, KeepsBytesFormatAndTimeExactly) {
  TempFolder dir;
  auto store = open_directory_store(dir.path, {});
  store->put(kId, upload_of(binary_bytes(100000), MeshFormat::glb));
  const auto found = store->get(kId);
  ASSERT_TRUE(found.upload.has_value());
  EXPECT_EQ(found.upload->bytes, binary_bytes(100000));
  EXPECT_EQ(found.upload->format, MeshFormat::glb);
  EXPECT_EQ(found.upload->uploaded_at_unix_s, 1764576000);
  EXPECT_TRUE(fs::is_empty(dir.path / "tmp"));  // the temporary file became the upload
  EXPECT_EQ(store->bytes(), fs::file_size(dir.path / "uploads" / kId));
}

TEST(DirectoryStore, SurvivesReopeningAndDropsInterruptedWrites) {
  TempFolder dir;
  open_directory_store(dir.path, {})->put(kId, upload_of("OFF\n3 1 0\n"));
  std::ofstream(dir.path / "tmp" / (kId + ".half")) << "a write a crash interrupted";
  auto reopened = open_directory_store(dir.path, {});
  const auto found = reopened->get(kId);
  ASSERT_TRUE(found.upload.has_value());
  EXPECT_EQ(found.upload->bytes, "OFF\n3 1 0\n");
  EXPECT_TRUE(fs::is_empty(dir.path / "tmp"));
  EXPECT_EQ(reopened->bytes(), fs::file_size(dir.path / "uploads" / kId));
}

TEST(DirectoryStore, TellsDeletedFromUnknown) {
  TempFolder dir;
  auto store = open_directory_store(dir.path, {});
  store->put(kId, upload_of("x"));
  EXPECT_TRUE(store->touch(kId));
  EXPECT_TRUE(store->erase(kId));
  EXPECT_FALSE(store->erase(kId));
  EXPECT_FALSE(store->touch(kId));
  EXPECT_FALSE(store->get(kId).upload.has_value());
  EXPECT_EQ(store->get(kId).why, StoreMiss::deleted);
  EXPECT_EQ(store->get(kOtherId).why, StoreMiss::unknown);
  EXPECT_EQ(store->bytes(), 0u);
}

TEST(DirectoryStore, ExpiresIdleUploadsAndLaterForgetsThem) {
  TempFolder dir;
  FakeWallClock clock;
  StoreOptions options;
  options.idle_ttl = std::chrono::seconds(60);
  options.tombstone_ttl = std::chrono::seconds(600);
  options.now = clock.fn();
  auto store = open_directory_store(dir.path, options);
  store->put(kId, upload_of("a"));
  store->put(kOtherId, upload_of("b"));
  clock.now += std::chrono::seconds(50);
  store->touch(kId);  // used at 50 s: expires at 110 s; the other one at 60 s
  clock.now += std::chrono::seconds(20);
  EXPECT_EQ(store->expire_idle(), 1u);
  EXPECT_TRUE(store->get(kId).upload.has_value());
  EXPECT_EQ(store->get(kOtherId).why, StoreMiss::expired);
  clock.now += std::chrono::seconds(41);
  EXPECT_EQ(store->expire_idle(), 1u);
  EXPECT_EQ(store->get(kId).why, StoreMiss::expired);
  clock.now += std::chrono::seconds(601);  // past the tombstone period: no longer remembered
  store->expire_idle();
  EXPECT_EQ(store->get(kId).why, StoreMiss::unknown);
}

TEST(DirectoryStore, RefusesBeyondItsSizeLimitAndKeepsNothingOfTheRefused) {
  TempFolder dir;
  StoreOptions options;
  options.max_bytes = 1000;
  auto store = open_directory_store(dir.path, options);
  store->put(kId, upload_of(std::string(600, 'a')));
  EXPECT_THROW(store->put(kOtherId, upload_of(std::string(600, 'b'))), StoreFullError);
  EXPECT_EQ(store->get(kOtherId).why, StoreMiss::unknown);
  EXPECT_TRUE(fs::is_empty(dir.path / "tmp"));
  ASSERT_TRUE(store->erase(kId));
  EXPECT_NO_THROW(store->put(kOtherId, upload_of(std::string(600, 'b'))));
}

TEST(DirectoryStore, AVanishedFolderIsUnavailableNotEmpty) {
  TempFolder dir;
  auto store = open_directory_store(dir.path / "store", {});
  store->put(kId, upload_of("x"));
  fs::remove_all(dir.path / "store");
  EXPECT_THROW(store->get(kId), StoreUnavailableError);
  EXPECT_THROW(store->put(kOtherId, upload_of("y")), StoreUnavailableError);
  std::ofstream(dir.path / "a_file") << "not a folder";
  EXPECT_THROW(open_directory_store(dir.path / "a_file", {}), StoreUnavailableError);
}

TEST(DirectoryStore, RefusesDamagedRecordsAndForeignIds) {
  TempFolder dir;
  auto store = open_directory_store(dir.path, {});
  std::ofstream(dir.path / "uploads" / kId) << "{\"format\": \"off\", \"uploaded_at\": 1, \"bytes\": 99}\nshort";
  EXPECT_THROW(store->get(kId), StoreUnavailableError);
  EXPECT_EQ(store->get("../uploads/" + kId).why, StoreMiss::unknown);
  EXPECT_THROW(store->put("../../etc/passwd", upload_of("x")), std::invalid_argument);
}

TEST(UploadStoreUrl, ParsesRedisAndFolderForms) {
  TempFolder dir;
  EXPECT_EQ(open_upload_store("dir:" + dir.path.string(), {})->describe(), "directory " + dir.path.string());
  EXPECT_EQ(open_upload_store(dir.path.string(), {})->describe(), "directory " + dir.path.string());
  // Nothing listens on port 1: the store opens (Redis may come later) and says where it points.
  EXPECT_EQ(open_upload_store("redis://127.0.0.1:1/2", {})->describe(), "redis 127.0.0.1:1/2");
  EXPECT_THROW(open_upload_store("redis://127.0.0.1:notaport", {}), std::invalid_argument);
  EXPECT_THROW(open_upload_store("redis://:6379", {}), std::invalid_argument);
}

TEST(UploadStoreUrl, ReadsPercentEncodedCredentials) {
  const RedisAddress a = parse_redis_url("redis://:s3cr%2Ft%40x%3a%25@redis.example:6380/3");
  EXPECT_EQ(a.user, "");
  EXPECT_EQ(a.password, "s3cr/t@x:%");
  EXPECT_EQ(a.host, "redis.example");
  EXPECT_EQ(a.port, 6380);
  EXPECT_EQ(a.db, 3);
  // Unencoded @, / and : in a password: the last @ ends it, the first : after the user starts it.
  const RedisAddress b = parse_redis_url("redis://featureline:p@ss/w:rd@10.0.0.5");
  EXPECT_EQ(b.user, "featureline");
  EXPECT_EQ(b.password, "p@ss/w:rd");
  EXPECT_EQ(b.host, "10.0.0.5");
  EXPECT_EQ(b.port, 6379);
  EXPECT_EQ(b.db, 0);
  const RedisAddress c = parse_redis_url("redis://featureline@h:1");  // a user, no password
  EXPECT_EQ(c.user, "featureline");
  EXPECT_EQ(c.password, "");
  const RedisAddress d = parse_redis_url("redis://h:1/2");
  EXPECT_EQ(d.user + d.password, "");
}

TEST(UploadStoreUrl, ShowsCredentialsNowhere) {
  EXPECT_EQ(redacted_store_url("redis://user:secret@h:1/2"), "redis://***@h:1/2");
  EXPECT_EQ(redacted_store_url("redis://:p@ss@h"), "redis://***@h");
  EXPECT_EQ(redacted_store_url("redis://h:1/2"), "redis://h:1/2");
  EXPECT_EQ(redacted_store_url("dir:/srv/a@b"), "dir:/srv/a@b");
  for (const std::string url : {"redis://:secret%zz@h:1", "redis://:secret@h:notaport", "redis://:secret@h/100", "redis://:secret@"}) {
    try {
      parse_redis_url(url);
      ADD_FAILURE() << "accepted a malformed URL";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).find("secret"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("redis://***@"), std::string::npos) << e.what();
    }
  }
}

TEST(UploadStoreUrl, APasswordFromElsewhereWhenTheUrlHasNone) {
  // Nothing listens on port 1: the store opens (Redis may come later).
  EXPECT_EQ(open_upload_store("redis://ci@127.0.0.1:1", {}, "from-the-environment")->describe(), "redis 127.0.0.1:1/0");
  try {
    open_upload_store("redis://ci@127.0.0.1:1", {});
    ADD_FAILURE() << "a user without a password was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("names a user but no password"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(kRedisPasswordVariable), std::string::npos) << e.what();
  }
}

// ---- Redis ------------------------------------------------------------------------------------

int free_loopback_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    close(fd);
    return -1;
  }
  close(fd);
  return ntohs(addr.sin_port);
}

bool port_answers(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(std::uint16_t(port));
  const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  close(fd);
  return ok;
}

// Whether process `pid` holds a socket listening on 127.0.0.1:`port`: its fds against the kernel's
// table of listening TCP sockets. A port that merely answers may belong to another test's
// server: a free port is picked, released and bound later, and tests run side by side.
bool listens_on(pid_t pid, int port) {
  std::ifstream table("/proc/net/tcp");
  std::string line;
  std::getline(table, line);  // header
  std::vector<std::string> inodes;
  char local_port[8];
  std::snprintf(local_port, sizeof local_port, ":%04X", port);
  while (std::getline(table, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
    fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >> inode;
    if (state == "0A" && local.size() > 5 && local.compare(local.size() - 5, 5, local_port) == 0)
      inodes.push_back("socket:[" + inode + "]");
  }
  std::error_code error;
  fs::directory_iterator fd("/proc/" + std::to_string(pid) + "/fd", error), end;
  for (; !error && fd != end; fd.increment(error)) {  // the process may exit meanwhile
    const auto target = fs::read_symlink(fd->path(), error);
    if (!error && std::find(inodes.begin(), inodes.end(), target.string()) != inodes.end()) return true;
    error.clear();
  }
  return false;
}

// A real redis-server on a free loopback port, without persistence, stopped by its PID. When the
// port it was given is taken before it binds, it starts again on another (a port of the test's
// own choosing is tried again as it is, a few times).
class RedisProcess {
 public:
  /// `extra`: more redis-server arguments (--requirepass, --user).
  explicit RedisProcess(std::string policy = "noeviction", int port = 0, std::vector<std::string> extra = {}) {
    for (int attempt = 0; attempt < 5 && pid_ <= 0; ++attempt) {
      port_ = port != 0 ? port : free_loopback_port();
      start(policy, extra);
      if (!wait_until_listening()) stop();
    }
  }
  ~RedisProcess() { stop(); }
  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGCONT);
    kill(pid_, SIGTERM);
    int status = 0;
    for (int i = 0; i < 100 && waitpid(pid_, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (waitpid(pid_, &status, WNOHANG) == 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
    }
    pid_ = -1;
  }
  bool up() const { return pid_ > 0 && listens_on(pid_, port_) && port_answers(port_); }
  int port() const { return port_; }
  // A hung Redis: the kernel still accepts connections and takes commands, nothing answers.
  void pause() const { kill(pid_, SIGSTOP); }
  void resume() const { kill(pid_, SIGCONT); }

 private:
  void start(const std::string& policy, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"redis-server", "--port", std::to_string(port_), "--bind", "127.0.0.1", "--save", "",
                                     "--appendonly", "no", "--maxmemory", "8mb", "--maxmemory-policy", policy,
                                     "--loglevel", "warning", "--dir", "/tmp"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    if (pid_ == 0) {
      const int null = open("/dev/null", O_WRONLY);  // Redis' start-up banner is not test output
      dup2(null, 1);
      execv("/usr/bin/redis-server", argv.data());
      _exit(127);
    }
  }
  // Until this process listens on the port (5 s at most); false when it exited (the port was
  // taken) or never did.
  bool wait_until_listening() {
    int status = 0;
    for (int i = 0; i < 100; ++i) {
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return false;
      }
      if (listens_on(pid_, port_)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }

  int port_ = -1;
  pid_t pid_ = -1;
};

RedisAddress address_of(int port) {
  RedisAddress a;
  a.port = port;
  a.key_prefix = "test";
  a.timeout = std::chrono::milliseconds(1000);
  return a;
}

TEST(RedisStore, ReplicasShareUploadsAndDeletes) {
  RedisProcess redis;
  ASSERT_TRUE(redis.up()) << "redis-server did not start (scripts/setup.sh installs it)";
  auto replica_a = open_redis_store(address_of(redis.port()), {});
  auto replica_b = open_redis_store(address_of(redis.port()), {});
  replica_a->put(kId, upload_of(binary_bytes(300000), MeshFormat::ply));
  const auto found = replica_b->get(kId);
  ASSERT_TRUE(found.upload.has_value());
  EXPECT_EQ(found.upload->bytes, binary_bytes(300000));
  EXPECT_EQ(found.upload->format, MeshFormat::ply);
  EXPECT_EQ(found.upload->uploaded_at_unix_s, 1764576000);
  EXPECT_TRUE(replica_b->erase(kId));
  EXPECT_FALSE(replica_a->erase(kId));
  EXPECT_EQ(replica_a->get(kId).why, StoreMiss::deleted);
  EXPECT_EQ(replica_a->get(kOtherId).why, StoreMiss::unknown);
}

TEST(RedisStore, IdleUploadsExpireAndAreReportedExpired) {
  RedisProcess redis;
  ASSERT_TRUE(redis.up());
  StoreOptions options;
  options.idle_ttl = std::chrono::seconds(1);
  auto store = open_redis_store(address_of(redis.port()), options);
  store->put(kId, upload_of("x"));
  StoreLookup found = store->get(kId);
  // Redis expires the key itself; wait for it (bounded: 50 x 100 ms).
  for (int i = 0; i < 50 && found.upload; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    found = store->get(kId);
  }
  EXPECT_FALSE(found.upload.has_value());
  EXPECT_EQ(found.why, StoreMiss::expired);
}

TEST(RedisStore, FullRedisRefusesWithStoreFullAndKeepsWhatItHad) {
  RedisProcess redis;  // maxmemory 8 MB, noeviction
  ASSERT_TRUE(redis.up());
  auto store = open_redis_store(address_of(redis.port()), {});
  std::vector<std::string> kept;
  bool refused = false;
  for (int i = 0; i < 40 && !refused; ++i) {
    const std::string id = random_session_id();
    try {
      store->put(id, upload_of(binary_bytes(1 << 20)));
      kept.push_back(id);
    } catch (const StoreFullError&) {
      refused = true;
      EXPECT_EQ(store->get(id).why, StoreMiss::unknown);  // nothing of the refused upload
    }
  }
  EXPECT_TRUE(refused);
  EXPECT_GE(kept.size(), 3u);
  for (const auto& id : kept) EXPECT_TRUE(store->get(id).upload.has_value()) << id;
}

TEST(RedisStore, UnreachableIsUnavailableAndReconnectsWhenRedisReturns) {
  const int port = free_loopback_port();
  auto store = open_redis_store(address_of(port), {});  // nothing listens yet
  EXPECT_THROW(store->put(kId, upload_of("x")), StoreUnavailableError);
  EXPECT_THROW(store->get(kId), StoreUnavailableError);
  {
    RedisProcess redis("noeviction", port);
    ASSERT_TRUE(redis.up());
    store->put(kId, upload_of("x"));
    EXPECT_TRUE(store->get(kId).upload.has_value());
    redis.stop();  // the pooled connection is now dead
    EXPECT_THROW(store->get(kId), StoreUnavailableError);
  }
  RedisProcess again("noeviction", port);
  ASSERT_TRUE(again.up());
  EXPECT_EQ(store->get(kId).why, StoreMiss::unknown);  // a new, empty Redis: reconnected
}

// Pooled connections that Redis closed when it restarted are dropped before use: no operation
// after the restart fails (before, the first few per replica answered 503, one per stale connection).
TEST(RedisStore, ConnectionsClosedByARestartAreReplacedNotFailed) {
  const int port = free_loopback_port();
  auto store = open_redis_store(address_of(port), {});
  {
    RedisProcess redis("noeviction", port);
    ASSERT_TRUE(redis.up());
    std::vector<std::thread> threads;  // concurrent operations leave several connections in the pool
    for (int i = 0; i < 6; ++i) threads.emplace_back([&] { store->put(kId, upload_of("x")); });
    for (auto& t : threads) t.join();
  }
  RedisProcess again("noeviction", port);
  ASSERT_TRUE(again.up());
  int failures = 0;
  for (int i = 0; i < 10; ++i) {
    try {
      store->put(kOtherId, upload_of("y"));
      store->get(kOtherId);
    } catch (const StoreUnavailableError&) {
      ++failures;
    }
  }
  EXPECT_EQ(failures, 0);
  EXPECT_TRUE(store->get(kOtherId).upload.has_value());
}

// Redis restarted without its data: every replica that knew it counts one loss, once; a replica
// that starts afterwards knows nothing lost; a restart that keeps the data is no loss.
TEST(RedisStore, ARedisThatLostItsDataIsCountedOnceByEveryReplicaThatKnewIt) {
  const int port = free_loopback_port();
  FakeWallClock clock;
  StoreOptions options;
  options.now = clock.fn();
  std::unique_ptr<UploadStore> replica_a, replica_b;
  {
    RedisProcess redis("noeviction", port);
    ASSERT_TRUE(redis.up());
    replica_a = open_redis_store(address_of(port), options);
    replica_b = open_redis_store(address_of(port), options);
    replica_a->put(kId, upload_of("x"));
    replica_b->probe();
    EXPECT_EQ(replica_a->losses().count, 0u);
  }
  RedisProcess empty("noeviction", port);
  ASSERT_TRUE(empty.up());
  clock.now += std::chrono::seconds(100);
  EXPECT_EQ(replica_a->get(kId).why, StoreMiss::unknown);
  EXPECT_EQ(replica_a->losses().count, 1u);
  EXPECT_EQ(replica_a->losses().last_unix_s, 1764576100);
  replica_a->get(kId);
  replica_a->put(kOtherId, upload_of("y"));
  EXPECT_EQ(replica_a->losses().count, 1u);  // once, however often it is seen
  EXPECT_FALSE(replica_b->touch(kId));
  EXPECT_EQ(replica_b->losses().count, 1u);
  auto started_after = open_redis_store(address_of(port), options);
  EXPECT_TRUE(started_after->get(kOtherId).upload.has_value());
  EXPECT_EQ(started_after->losses().count, 0u);
}

TEST(RedisStore, RefusesARedisThatEvictsKeys) {
  RedisProcess redis("allkeys-lru");
  ASSERT_TRUE(redis.up());
  try {
    open_redis_store(address_of(redis.port()), {});
    FAIL() << "an evicting Redis was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("maxmemory-policy allkeys-lru"), std::string::npos) << e.what();
  }
}

// ---- Redis with a password --------------------------------------------------------------------

const std::string kPassword = "pw-7f3a9c0e5b1d";

RedisAddress address_with(int port, std::string password, std::string user = "") {
  RedisAddress a = address_of(port);
  a.password = std::move(password);
  a.user = std::move(user);
  return a;
}

// What open_redis_store threw, "" when it opened.
std::string auth_error_at_open(const RedisAddress& address) {
  try {
    open_redis_store(address, {});
  } catch (const StoreAuthError& e) {
    return e.what();
  }
  return "";
}

// A store opened before Redis starts, used across two restarts: every new connection,
// including those that replace the pooled ones Redis closed, authenticates.
TEST(RedisAuth, ThePasswordIsSentOnEveryNewConnection) {
  const int port = free_loopback_port();
  auto store = open_redis_store(address_with(port, kPassword), {});  // nothing listens yet
  for (int run = 0; run < 2; ++run) {
    RedisProcess redis("noeviction", port, {"--requirepass", kPassword});
    ASSERT_TRUE(redis.up());
    std::atomic<int> failures{0};
    std::vector<std::thread> threads;  // several connections in the pool
    for (int i = 0; i < 6; ++i) {
      threads.emplace_back([&] {
        try {
          store->put(kId, upload_of("x"));
        } catch (const StoreUnavailableError&) {
          ++failures;
        }
      });
    }
    for (auto& t : threads) t.join();
    for (int i = 0; i < 10; ++i) {
      try {
        store->put(kOtherId, upload_of("y"));
        failures += store->get(kOtherId).upload.has_value() ? 0 : 1;
      } catch (const StoreUnavailableError& e) {
        if (failures++ == 0) ADD_FAILURE() << e.what();
      }
    }
    EXPECT_EQ(failures, 0) << "run " << run;
  }
}

TEST(RedisAuth, AWrongPasswordIsRefusedAtOpenAndNotShown) {
  RedisProcess redis("noeviction", 0, {"--requirepass", kPassword});
  ASSERT_TRUE(redis.up());
  const std::string error = auth_error_at_open(address_with(redis.port(), "wrong-password-31d4"));
  EXPECT_NE(error.find("refused the password"), std::string::npos) << error;
  EXPECT_NE(error.find(kRedisPasswordVariable), std::string::npos) << error;
  EXPECT_EQ(error.find("wrong-password-31d4"), std::string::npos) << error;
  EXPECT_EQ(error.find(kPassword), std::string::npos) << error;
}

TEST(RedisAuth, NoPasswordForARedisThatWantsOneIsRefusedAtOpen) {
  RedisProcess redis("noeviction", 0, {"--requirepass", kPassword});
  ASSERT_TRUE(redis.up());
  for (int db : {0, 2}) {  // NOAUTH answers CONFIG GET, or SELECT before it
    RedisAddress address = address_of(redis.port());
    address.db = db;
    const std::string error = auth_error_at_open(address);
    EXPECT_NE(error.find("requires a password and none was given"), std::string::npos) << error;
    EXPECT_NE(error.find(kRedisPasswordVariable), std::string::npos) << error;
  }
}

TEST(RedisAuth, APasswordForARedisWithoutOneIsRefused) {
  RedisProcess redis;
  ASSERT_TRUE(redis.up());
  const std::string error = auth_error_at_open(address_with(redis.port(), kPassword));
  EXPECT_NE(error.find("refused AUTH"), std::string::npos) << error;
  EXPECT_EQ(error.find(kPassword), std::string::npos) << error;
}

// An ACL user that may not run CONFIG (its eviction check is skipped) and may touch only its keys.
TEST(RedisAuth, AnAclUserAuthenticatesWithItsOwnPassword) {
  RedisProcess redis("noeviction", 0,
                     {"--requirepass", "default-user-pw", "--user", "ci", "on", ">" + kPassword, "~test:*", "+@all", "-@dangerous"});
  ASSERT_TRUE(redis.up());
  auto store = open_redis_store(address_with(redis.port(), kPassword, "ci"), {});
  store->put(kId, upload_of("x"));
  EXPECT_TRUE(store->get(kId).upload.has_value());
  EXPECT_NE(auth_error_at_open(address_with(redis.port(), kPassword + "-not", "ci")).find("refused the password"), std::string::npos);
  // The same password for the default user, whose password is another.
  EXPECT_NE(auth_error_at_open(address_with(redis.port(), kPassword)).find("refused the password"), std::string::npos);
}

// Redis restarted with another password: operations fail as unavailable (503, /readyz), saying
// why, until it has the store's password again.
TEST(RedisAuth, APasswordChangedUnderARunningStoreIsUnavailableUntilItMatches) {
  const int port = free_loopback_port();
  std::unique_ptr<UploadStore> store;
  {
    RedisProcess redis("noeviction", port, {"--requirepass", kPassword});
    ASSERT_TRUE(redis.up());
    store = open_redis_store(address_with(port, kPassword), {});
    store->put(kId, upload_of("x"));
  }
  {
    RedisProcess changed("noeviction", port, {"--requirepass", "another-password-88"});
    ASSERT_TRUE(changed.up());
    try {
      store->probe();
      ADD_FAILURE() << "a refused password went unnoticed";
    } catch (const StoreUnavailableError& e) {
      EXPECT_NE(std::string(e.what()).find("refused the password"), std::string::npos) << e.what();
    }
  }
  RedisProcess back("noeviction", port, {"--requirepass", kPassword});
  ASSERT_TRUE(back.up());
  EXPECT_NO_THROW(store->probe());
}

// ---- DurableSessions --------------------------------------------------------------------------

struct Rebuilds {
  std::atomic<int> count{0};
  DurableSessions::Rebuild fn() {
    return [this](std::shared_ptr<const StoredUpload> upload) {
      ++count;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // long enough for waiters to pile up
      static const auto mesh = prepare_mesh(featureline::testing::make_icosphere(1.0, 1));
      MeshSession s;
      s.mesh = mesh;
      s.format = upload->format;
      s.bytes = upload->bytes.size();
      return s;
    };
  }
};

MeshSession fresh_session(std::size_t bytes) {
  MeshSession s;
  s.mesh = prepare_mesh(featureline::testing::make_icosphere(1.0, 1));
  s.bytes = bytes;
  return s;
}

TEST(DurableSessions, ARestartCostsARebuildNotTheSession) {
  TempFolder dir;
  Rebuilds rebuilds;
  std::string id;
  {
    SessionCache cache({1 << 20, std::chrono::seconds(60)});
    DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
    id = (*sessions.create(fresh_session(100), upload_of(std::string(100, 'm'))))->id;
    EXPECT_FALSE(sessions.find(id).rebuilt);
  }
  SessionCache cache({1 << 20, std::chrono::seconds(60)});  // the process restarted
  DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
  const auto found = sessions.find(id);
  ASSERT_NE(found.session, nullptr);
  EXPECT_TRUE(found.rebuilt);
  EXPECT_EQ(found.session->id, id);
  EXPECT_EQ(found.session->bytes, 100u);
  EXPECT_EQ(rebuilds.count, 1);
  EXPECT_FALSE(sessions.find(id).rebuilt);  // cached again
}

TEST(DurableSessions, AStashedUploadIsPreparedOnceWhereItIsFirstFoundAndCountedAsTakenOver) {
  TempFolder dir;
  Rebuilds rebuilds;
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
  const std::string id = sessions.stash(upload_of("stashed"));
  EXPECT_EQ(id.size(), 32u);
  EXPECT_EQ(cache.stats().entries, 0u);  // stored, not prepared
  EXPECT_EQ(rebuilds.count, 0);
  EXPECT_TRUE(open_directory_store(dir.path, {})->get(id).upload.has_value());
  const auto found = sessions.find_stashed(id);
  ASSERT_NE(found.session, nullptr);
  EXPECT_TRUE(found.rebuilt);
  EXPECT_EQ(found.session->id, id);
  EXPECT_EQ(rebuilds.count, 1);
  EXPECT_EQ(sessions.handoffs(), 1u);
  EXPECT_EQ(sessions.rebuilds(), 0u);
  EXPECT_FALSE(sessions.find(id).rebuilt);  // cached where it was prepared
  EXPECT_EQ(rebuilds.count, 1);
}

TEST(DurableSessions, StashNeedsAStore) {
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  Rebuilds rebuilds;
  DurableSessions sessions(cache, nullptr, rebuilds.fn(), {});
  EXPECT_THROW(sessions.stash(upload_of("x")), std::logic_error);
}

TEST(DurableSessions, ManyWaitersOnAMissingSessionShareOneRebuild) {
  TempFolder dir;
  Rebuilds rebuilds;
  auto store = open_directory_store(dir.path, {});
  store->put(kId, upload_of("stored"));
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, std::move(store), rebuilds.fn(), {});
  std::vector<std::thread> threads;
  std::atomic<int> answered{0};
  for (int i = 0; i < 8; ++i)
    threads.emplace_back([&] { answered += sessions.find(kId).session != nullptr ? 1 : 0; });
  for (auto& t : threads) t.join();
  EXPECT_EQ(answered, 8);
  EXPECT_EQ(rebuilds.count, 1);
  EXPECT_EQ(sessions.rebuilds(), 1u);
}

TEST(DurableSessions, EvictionCostsARebuildWithAStoreAndTheSessionWithout) {
  TempFolder dir;
  Rebuilds rebuilds;
  SessionCache cache({150, std::chrono::seconds(60)});  // room for one session of 100 bytes
  DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
  const auto first = (*sessions.create(fresh_session(100), upload_of(std::string(100, 'a'))))->id;
  sessions.create(fresh_session(100), upload_of(std::string(100, 'b')));  // evicts the first
  EXPECT_TRUE(sessions.find(first).rebuilt);

  SessionCache memory_only({150, std::chrono::seconds(60)});
  DurableSessions no_store(memory_only, nullptr, rebuilds.fn(), {});
  const auto lost = (*no_store.create(fresh_session(100), upload_of("a")))->id;
  no_store.create(fresh_session(100), upload_of("b"));
  const auto found = no_store.find(lost);
  EXPECT_EQ(found.session, nullptr);
  EXPECT_EQ(found.why, DurableSessions::Gone::evicted);
}

TEST(DurableSessions, DeleteRemovesTheStoredUploadAndIsReportedDeleted) {
  TempFolder dir;
  Rebuilds rebuilds;
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
  const auto id = (*sessions.create(fresh_session(10), upload_of("x")))->id;
  ASSERT_TRUE(sessions.erase(id, nullptr));
  EXPECT_FALSE(fs::exists(dir.path / "uploads" / id));
  auto why = DurableSessions::Gone::unknown;
  EXPECT_FALSE(sessions.erase(id, &why));
  EXPECT_EQ(why, DurableSessions::Gone::deleted);
  EXPECT_EQ(sessions.find(id).why, DurableSessions::Gone::deleted);
  EXPECT_EQ(sessions.find(kOtherId).why, DurableSessions::Gone::unknown);
  EXPECT_EQ(rebuilds.count, 0);
}

TEST(DurableSessions, ADeleteOnOneReplicaReachesAnotherReplicasCache) {
  RedisProcess redis;
  ASSERT_TRUE(redis.up());
  Rebuilds rebuilds;
  SessionCache cache_a({1 << 20, std::chrono::seconds(60)}), cache_b({1 << 20, std::chrono::seconds(60)});
  DurableSessions replica_a(cache_a, open_redis_store(address_of(redis.port()), {}), rebuilds.fn(), {});
  DurableSessions replica_b(cache_b, open_redis_store(address_of(redis.port()), {}), rebuilds.fn(), {});
  const auto id = (*replica_a.create(fresh_session(10), upload_of("shared")))->id;
  ASSERT_TRUE(replica_b.find(id).rebuilt);  // now cached on both
  ASSERT_NE(replica_b.find(id).session, nullptr);
  ASSERT_TRUE(replica_a.erase(id, nullptr));
  const auto found = replica_b.find(id);  // a cache hit on b, but the store says deleted
  EXPECT_EQ(found.session, nullptr);
  EXPECT_EQ(found.why, DurableSessions::Gone::deleted);
  EXPECT_EQ(cache_b.stats().entries, 0u);
}

// Redis restarted empty: a session cached on a replica is reported lost by the store (not
// deleted), on every replica and on every later request; an id the replica never had says the
// store lost its data; new uploads work at once.
TEST(DurableSessions, ASessionWhoseUploadRedisLostIsReportedLostNotDeleted) {
  const int port = free_loopback_port();
  Rebuilds rebuilds;
  SessionCache cache_a({1 << 20, std::chrono::seconds(60)}), cache_b({1 << 20, std::chrono::seconds(60)});
  std::string id;
  auto redis = std::make_unique<RedisProcess>("noeviction", port);
  ASSERT_TRUE(redis->up());
  DurableSessions replica_a(cache_a, open_redis_store(address_of(port), {}), rebuilds.fn(), {});
  DurableSessions replica_b(cache_b, open_redis_store(address_of(port), {}), rebuilds.fn(), {});
  id = (*replica_a.create(fresh_session(10), upload_of("x")))->id;
  ASSERT_TRUE(replica_b.find(id).rebuilt);
  redis.reset();
  redis = std::make_unique<RedisProcess>("noeviction", port);  // restarted, empty
  ASSERT_TRUE(redis->up());
  EXPECT_EQ(replica_a.find(id).why, DurableSessions::Gone::lost);
  EXPECT_EQ(replica_a.find(id).why, DurableSessions::Gone::lost);  // remembered once dropped
  EXPECT_EQ(replica_b.find(id).why, DurableSessions::Gone::lost);
  EXPECT_EQ(replica_a.find(kOtherId).why, DurableSessions::Gone::unknown_after_loss);
  const auto fresh = (*replica_a.create(fresh_session(10), upload_of("y")))->id;
  EXPECT_NE(replica_b.find(fresh).session, nullptr);
  ASSERT_TRUE(replica_a.erase(fresh, nullptr));
  EXPECT_EQ(replica_b.find(fresh).why, DurableSessions::Gone::deleted);  // a delete is still a delete
}

// Redis stopped (SIGSTOP): after consecutive timeouts the breaker opens; cached sessions answer
// without the store, everything that needs the store fails at once (not with a timeout), and
// the breaker closes by itself once Redis answers its probe.
TEST(StoreBreaker, OpensAfterTimeoutsServesTheCacheAndClosesWhenTheStoreAnswers) {
  RedisProcess redis;
  ASSERT_TRUE(redis.up());
  Rebuilds rebuilds;
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  auto breaker_owned = std::make_unique<StoreBreaker>(open_redis_store(address_of(redis.port()), {}),
                                                      BreakerOptions{2, std::chrono::milliseconds(100)});
  StoreBreaker& breaker = *breaker_owned;
  DurableSessions sessions(cache, std::move(breaker_owned), rebuilds.fn(), {});
  const auto id = (*sessions.create(fresh_session(10), upload_of("x")))->id;
  redis.pause();
  EXPECT_THROW(sessions.find(kOtherId), StoreTimeoutError);
  EXPECT_FALSE(breaker.open());
  EXPECT_NE(sessions.find(id).session, nullptr);  // its refresh timed out: the second in a row
  ASSERT_TRUE(breaker.open());
  EXPECT_EQ(breaker.openings(), 1u);
  for (int i = 0; i < 3; ++i) EXPECT_NE(sessions.find(id).session, nullptr);
  try {
    sessions.find(kOtherId);
    ADD_FAILURE() << "a lookup that needs the store answered while the breaker is open";
  } catch (const StoreTimeoutError& e) {
    ADD_FAILURE() << "waited for the store: " << e.what();
  } catch (const StoreUnavailableError& e) {
    EXPECT_NE(std::string(e.what()).find("fail at once"), std::string::npos) << e.what();
  }
  EXPECT_THROW(sessions.create(fresh_session(10), upload_of("y")), StoreUnavailableError);
  EXPECT_EQ(cache.stats().entries, 1u);
  redis.resume();
  for (int i = 0; i < 100 && breaker.open(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(breaker.open());
  EXPECT_EQ(sessions.find(kOtherId).why, DurableSessions::Gone::unknown);
  EXPECT_NE(sessions.find(id).session, nullptr);
}

TEST(DurableSessions, AStoreThatRefusesLeavesNoSession) {
  TempFolder dir;
  Rebuilds rebuilds;
  StoreOptions tiny;
  tiny.max_bytes = 10;
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, open_directory_store(dir.path, tiny), rebuilds.fn(), {});
  EXPECT_THROW(sessions.create(fresh_session(10), upload_of(std::string(100, 'x'))), StoreFullError);
  EXPECT_EQ(cache.stats().entries, 0u);
}

TEST(DurableSessions, ADeleteTheStoreCannotDoKeepsTheSessionWhole) {
  TempFolder dir;
  Rebuilds rebuilds;
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, open_directory_store(dir.path / "store", {}), rebuilds.fn(), {});
  const auto id = (*sessions.create(fresh_session(10), upload_of("x")))->id;
  fs::remove_all(dir.path / "store");  // the store fails: the DELETE must fail whole
  EXPECT_THROW(sessions.erase(id, nullptr), StoreUnavailableError);
  EXPECT_EQ(cache.stats().entries, 1u);
  EXPECT_NE(sessions.find(id).session, nullptr);
}

TEST(DurableSessions, AStoredMeshThatCannotFitIsRefusedOnceAndRemembered) {
  TempFolder dir;
  std::string id;
  {
    SessionCache cache({1 << 20, std::chrono::seconds(60)});
    Rebuilds rebuilds;
    DurableSessions sessions(cache, open_directory_store(dir.path, {}), rebuilds.fn(), {});
    id = (*sessions.create(fresh_session(100), upload_of(std::string(100, 'm'))))->id;
  }
  // Restarted with less memory: preparing the upload again exceeds the budget.
  std::atomic<int> attempts{0};
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  DurableSessions sessions(cache, open_directory_store(dir.path, {}),
                           [&](std::shared_ptr<const StoredUpload>) -> MeshSession {
                             ++attempts;
                             throw LimitExceededError("the prepared mesh needs more than 5 MiB");
                           },
                           {});
  for (int i = 0; i < 3; ++i) {
    try {
      sessions.find(id);
      ADD_FAILURE() << "a mesh that cannot fit was served";
    } catch (const CacheTooSmallError& e) {
      EXPECT_NE(std::string(e.what()).find("cannot be prepared within this server's memory: the prepared mesh needs more than 5 MiB"),
                std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(attempts, 1);  // remembered: the upload is not read again per request
  EXPECT_TRUE(sessions.erase(id, nullptr));
  EXPECT_EQ(sessions.find(id).why, DurableSessions::Gone::deleted);
}

}  // namespace
}  // namespace featureline::server
