#include "common/files.hpp"

#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>

#include "common/errors.hpp"
#include "common/one_line.hpp"

namespace hpcgi::files {
namespace fs = std::filesystem;
namespace {

std::string kind_of(mode_t m) {
  if (S_ISDIR(m)) return "a folder";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  if (S_ISFIFO(m)) return "a FIFO";
  if (S_ISSOCK(m)) return "a socket";
  return "not a regular file";
}

std::string in_quotes(const std::string& path) { return "'" + one_line(path) + "'"; }

// Temporary files to remove on a signal that ends the process: fixed slots, so the handler touches no allocator.
constexpr int kSlots = 64;
char g_paths[kSlots][PATH_MAX];
std::atomic<bool> g_used[kSlots];

// The signals whose default action ends the process and that a user, a terminal, a batch system or a limit sends.
// While a temporary file exists, each is caught (its file removed, then the signal raised again with the action it
// had) unless it was ignored: a signal ignored when the first temporary file appears (nohup, a background job of
// a script: SIGINT and SIGQUIT) stays ignored and the run goes on (coreutils' rule). No temporary file left: every
// action is as it was, so a program's own choice (a test ignoring SIGXFSZ) is never overridden for long.
constexpr int kSignals[] = {SIGHUP, SIGINT, SIGQUIT, SIGPIPE, SIGTERM, SIGXCPU, SIGXFSZ};
constexpr int kSignalCount = sizeof kSignals / sizeof kSignals[0];
struct sigaction g_old[kSignalCount];
bool g_caught[kSignalCount];
std::mutex g_mutex;  // guards g_live, g_old, g_caught against two threads opening outputs at once
int g_live = 0;      // slots in use

void on_signal(int sig) {
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i].load()) unlink(g_paths[i]);
  for (int k = 0; k < kSignalCount; ++k)
    if (kSignals[k] == sig) sigaction(sig, &g_old[k], nullptr);  // what the program did before, usually die
  raise(sig);
}

void catch_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  for (int k = 0; k < kSignalCount; ++k) {
    g_caught[k] = sigaction(kSignals[k], nullptr, &g_old[k]) == 0 && g_old[k].sa_handler != SIG_IGN;
    if (g_caught[k]) sigaction(kSignals[k], &sa, nullptr);
  }
}

void restore_signals() {
  for (int k = 0; k < kSignalCount; ++k)
    if (g_caught[k]) sigaction(kSignals[k], &g_old[k], nullptr);
}

int register_temp(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  std::lock_guard<std::mutex> lock(g_mutex);
  for (int i = 0; i < kSlots; ++i) {
    if (g_used[i].load()) continue;
    std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
    if (g_live++ == 0) catch_signals();
    g_used[i].store(true);
    return i;
  }
  return -1;  // more than kSlots outputs open at once: still removed on errors, not on a signal
}

std::string folder_of(const std::string& target) {
  const fs::path p(target);
  return p.has_parent_path() ? p.parent_path().string() : std::string(".");
}

}  // namespace

std::string resolve_target(const std::string& path) {
  fs::path p(path);
  for (int hops = 0; hops < 40; ++hops) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(p, ec)) || ec) return p.string();
    fs::path next = fs::read_symlink(p, ec);
    if (ec) return p.string();
    p = next.is_absolute() ? next : p.parent_path() / next;
  }
  throw UsageError("too many levels of symbolic links at " + in_quotes(path));
}

void require_input(const std::string& path, const std::string& what) {
  struct stat st {};
  if (path.empty() || ::stat(path.c_str(), &st) != 0) return;  // a missing file: the loader says so in its words
  if (!S_ISREG(st.st_mode)) throw UsageError(what + " " + in_quotes(path) + " is " + kind_of(st.st_mode) + ", not a file");
}

void check_outputs(const std::vector<Output>& outputs, const std::vector<std::string>& inputs) {
  struct Known {
    std::string key, what;
    dev_t dev = 0;
    ino_t ino = 0;
    bool exists = false;
  };
  std::vector<Known> in, out;
  std::map<std::string, size_t> by_key;
  std::map<std::pair<dev_t, ino_t>, size_t> by_file;
  static const char* const kOneFile = "one file cannot be two outputs";
  for (const auto& p : inputs) {
    struct stat st {};
    if (!p.empty() && ::stat(p.c_str(), &st) == 0) in.push_back({p, p, st.st_dev, st.st_ino, true});
  }
  for (const Output& o : outputs) {
    if (o.path.empty()) continue;
    const std::string name = o.what + " " + in_quotes(o.path);
    const std::string target = resolve_target(o.path);
    if (fs::path(target).filename().string().size() > NAME_MAX)
      throw UsageError(name + ": a file name of more than " + std::to_string(NAME_MAX) + " bytes");
    Known k{fs::weakly_canonical(fs::absolute(target)).string(), o.what};
    struct stat st {};
    if (::stat(target.c_str(), &st) == 0) {
      if (!S_ISREG(st.st_mode))
        throw UsageError(name + " is " + kind_of(st.st_mode) + (o.append ? ": records are appended to a file only"
                                                                          : ": refusing to replace it (an output must be a file)"));
      if (::access(target.c_str(), W_OK) != 0) throw UsageError(name + " is not writable");
      k.dev = st.st_dev, k.ino = st.st_ino, k.exists = true;
      for (const Known& i : in)
        if (i.dev == k.dev && i.ino == k.ino)
          throw UsageError(name + " is the run's input " + in_quotes(i.what) + ": refusing to overwrite it");
    } else {
      const std::string dir = folder_of(target);
      std::error_code ec;
      if (o.append) fs::create_directories(dir, ec);
      struct stat ds {};
      if (::stat(dir.c_str(), &ds) != 0 || !S_ISDIR(ds.st_mode))
        throw UsageError(name + ": the folder " + in_quotes(dir) + " does not exist");
      if (::access(dir.c_str(), W_OK | X_OK) != 0) throw UsageError(name + ": the folder " + in_quotes(dir) + " is not writable");
    }
    // Indexed by name and by file: --png-frames checks a name per frame, 100000 of them.
    auto twice = by_key.emplace(k.key, out.size());
    if (!twice.second) throw UsageError(name + " is also given as " + out[twice.first->second].what + ": " + kOneFile);
    if (k.exists) {
      auto same = by_file.emplace(std::make_pair(k.dev, k.ino), out.size());
      if (!same.second) throw UsageError(name + " is also given as " + out[same.first->second].what + ": " + kOneFile);
    }
    out.push_back(k);
  }
}

// A temporary file's name is registered before the file exists, so that no signal finds it made and unknown (the
// handler's unlink of a name not yet made does nothing); O_EXCL then makes it ours, or another name is drawn.
std::string make_temp_beside(const std::string& path, int& slot) {
  const std::string dir = folder_of(resolve_target(path));
  static const char kChars[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
  std::random_device random;
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::string tmp = dir + "/.hpcgi-";
    for (int k = 0; k < 12; ++k) tmp += kChars[random() % (sizeof kChars - 1)];
    slot = register_temp(tmp);
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);  // the umask applies
    if (fd >= 0) {
      ::close(fd);
      return tmp;
    }
    const int err = errno;
    release_temp(slot);
    if (err != EEXIST) throw std::runtime_error("cannot write " + in_quotes(path) + ": " + std::strerror(err));
  }
  throw std::runtime_error("cannot write " + in_quotes(path) + ": no free temporary name beside it after 100 tries");
}

void release_temp(int slot) {
  if (slot < 0) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  g_used[slot].store(false);
  if (--g_live == 0) restore_signals();
}

AtomicFile::AtomicFile(const std::string& path) : path_(path), target_(resolve_target(path)) {
  tmp_ = make_temp_beside(path, slot_);
  f_ = std::fopen(tmp_.c_str(), "wb");
  if (!f_) fail(std::strerror(errno));
}

AtomicFile::~AtomicFile() {
  if (done_) return;
  if (f_) std::fclose(f_);
  ::unlink(tmp_.c_str());
  release_temp(slot_);
}

void AtomicFile::fail(const std::string& reason) {
  if (f_) std::fclose(f_);
  f_ = nullptr;
  ::unlink(tmp_.c_str());
  release_temp(slot_);
  done_ = true;
  throw std::runtime_error("cannot write " + in_quotes(path_) + ": " + reason);
}

void AtomicFile::commit() {
  // Buffered bytes reach the disk only here: a full disk shows at fflush, fsync or fclose.
  if (std::fflush(f_) != 0 || std::ferror(f_) || fsync(fileno(f_)) != 0) fail(std::strerror(errno ? errno : EIO));
  const int closed = std::fclose(f_);
  f_ = nullptr;
  if (closed != 0) fail(std::strerror(errno));
  if (std::rename(tmp_.c_str(), target_.c_str()) != 0) fail(std::strerror(errno));
  release_temp(slot_);
  done_ = true;
}

}  // namespace hpcgi::files
