// common/files: what a run may write, and how. Every node, FIFO and link here is made by the test in its own folder.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/errors.hpp"
#include "common/files.hpp"

namespace fs = std::filesystem;
using hpcgi::files::AtomicFile;
using hpcgi::files::check_outputs;

namespace {

struct Dir {
  fs::path p;
  Dir() {
    char t[] = "/tmp/hpcgi-files-XXXXXX";
    p = mkdtemp(t);
  }
  ~Dir() { fs::remove_all(p); }
  std::string operator/(const std::string& name) const { return (p / name).string(); }
};

void put(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
std::string get(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}
std::string refusal(const std::vector<hpcgi::files::Output>& outs, const std::vector<std::string>& ins = {}) {
  try {
    check_outputs(outs, ins);
  } catch (const hpcgi::UsageError& e) {
    return e.what();
  }
  return "";
}
size_t entries(const Dir& d) { return std::distance(fs::directory_iterator(d.p), fs::directory_iterator()); }

}  // namespace

TEST(Files, DeviceFifoAndFolderAreNeverReplaced) {
  Dir d;
  ASSERT_EQ(mkfifo((d / "fifo").c_str(), 0644), 0);
  fs::create_directory(d / "folder");
  EXPECT_NE(refusal({{d / "fifo", "--png"}}).find("is a FIFO: refusing to replace it"), std::string::npos);
  EXPECT_NE(refusal({{d / "folder", "-o"}}).find("is a folder"), std::string::npos);
  EXPECT_NE(refusal({{d / "fifo", "--record", true}}).find("records are appended to a file only"), std::string::npos);
  if (mknod((d / "mynull").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {  // root only
    EXPECT_NE(refusal({{d / "mynull", "--output"}}).find("is a character device"), std::string::npos);
    struct stat st {};
    ASSERT_EQ(stat((d / "mynull").c_str(), &st), 0);
    EXPECT_TRUE(S_ISCHR(st.st_mode));
  }
}

TEST(Files, InputsAndOtherOutputsAreNotOverwritten) {
  Dir d;
  put(d / "scene.xml", "<scene/>");
  fs::create_hard_link(d / "scene.xml", d / "alias.xml");
  EXPECT_NE(refusal({{d / "scene.xml", "-o"}}, {d / "scene.xml"}).find("is the run's input"), std::string::npos);
  EXPECT_NE(refusal({{d / "alias.xml", "-o"}}, {d / "scene.xml"}).find("is the run's input"), std::string::npos);
  EXPECT_NE(refusal({{d / "o.png", "--png"}, {d / "./o.png", "--output"}}).find("is also given as --png"),
            std::string::npos);
  EXPECT_EQ(get(d / "scene.xml"), "<scene/>");
  EXPECT_EQ(refusal({{d / "a.png", "--png"}, {d / "b.xml", "--output"}}, {d / "scene.xml"}), "");
}

TEST(Files, MissingFolderIsRefusedUpFrontButARecordsFolderIsMade) {
  Dir d;
  EXPECT_NE(refusal({{d / "nodir/out.ff", "-o"}}).find("does not exist"), std::string::npos);
  EXPECT_EQ(refusal({{d / "new/records.jsonl", "--record", true}}), "");
  EXPECT_TRUE(fs::is_directory(d / "new"));
  const std::string longest(250, 'n');  // a legal name: no ".tmp" appended to it
  EXPECT_EQ(refusal({{d / (longest + ".png"), "--png"}}), "");
  AtomicFile f(d / (longest + ".png"));
  std::fputs("x", f.stream());
  f.commit();
  EXPECT_EQ(get(d / (longest + ".png")), "x");
}

TEST(Files, ASymlinkIsWrittenThroughAndAnUnrelatedTmpIsLeftAlone) {
  Dir d;
  put(d / "real.png", "old");
  fs::create_symlink("real.png", d / "link.png");
  put(d / "link.png.tmp", "somebody's");
  put(d / "real.png.tmp", "somebody else's");
  EXPECT_EQ(refusal({{d / "link.png", "--png"}}), "");
  AtomicFile f(d / "link.png");
  std::fputs("new", f.stream());
  f.commit();
  EXPECT_TRUE(fs::is_symlink(d / "link.png"));
  EXPECT_EQ(get(d / "real.png"), "new");
  EXPECT_EQ(get(d / "link.png.tmp"), "somebody's");
  EXPECT_EQ(get(d / "real.png.tmp"), "somebody else's");
  EXPECT_EQ(entries(d), 4u);  // no temporary file of ours left
}

TEST(Files, AnUncommittedOrFailedFileLeavesNothing) {
  Dir d;
  put(d / "out.ff", "previous");
  {
    AtomicFile f(d / "out.ff");
    std::fputs("half", f.stream());
    EXPECT_TRUE(fs::exists(f.temp_path()));
  }  // destroyed uncommitted: an exception went through
  EXPECT_EQ(get(d / "out.ff"), "previous");
  EXPECT_EQ(entries(d), 1u);
  AtomicFile g(d / "out.ff");
  EXPECT_THROW(g.fail("disk full"), std::runtime_error);
  EXPECT_EQ(entries(d), 1u);
}

TEST(Files, TwoWritersOfOneOutputEachWriteAWholeFile) {
  Dir d;
  AtomicFile a(d / "out.ff"), b(d / "out.ff");
  EXPECT_NE(a.temp_path(), b.temp_path());
  std::fputs("run A", a.stream());
  std::fputs("run B, longer", b.stream());
  b.commit();
  EXPECT_EQ(get(d / "out.ff"), "run B, longer");
  a.commit();
  EXPECT_EQ(get(d / "out.ff"), "run A");
  EXPECT_EQ(entries(d), 1u);
}

namespace {

// The child of the signal tests, run by exec as a fresh process (as under nohup: a signal ignored before exec stays
// ignored, a caught one is reset to its default), before main: opens DIR/out.png, writes, says so on fd READY, waits
// for a byte on fd GO (through any signal it survives), then commits; exit 0 when the output was written, 3 if not.
const bool g_signal_child = [] {
  const char* spec = std::getenv("HPCGI_FILES_SIGNAL_CHILD");  // "DIR READY GO"
  if (!spec) return false;
  char dir[4096];
  int ready = -1, go = -1;
  if (std::sscanf(spec, "%4095s %d %d", dir, &ready, &go) != 3) _exit(9);
  try {
    AtomicFile f(std::string(dir) + "/out.png");
    std::fputs("whole", f.stream());
    std::fflush(f.stream());
    if (write(ready, "x", 1) != 1) _exit(9);
    char c;
    while (read(go, &c, 1) != 1) {  // a caught signal interrupts read: wait on
    }
    f.commit();
  } catch (const std::exception&) {
    _exit(3);
  }
  _exit(0);
}();

// Starts the child above with `sig` set to `action` (whatever the test process inherited: `trap "" INT` makes SIGINT
// ignored here), sends it `sig` while it writes, then lets it go on. Returns its wait status (a child still alive
// after 10 s is killed and -1 returned: the test fails, it never hangs) and whether the temporary file existed
// while it wrote.
int signalled_child(const Dir& d, int sig, void (*action)(int), bool& temp_seen) {
  int ready[2], go[2];
  if (pipe(ready) != 0 || pipe(go) != 0) return -1;
  const std::string spec = d.p.string() + " " + std::to_string(ready[1]) + " " + std::to_string(go[0]);
  const pid_t pid = fork();
  if (pid == 0) {
    signal(sig, action);
    setenv("HPCGI_FILES_SIGNAL_CHILD", spec.c_str(), 1);
    execl("/proc/self/exe", "/proc/self/exe", static_cast<char*>(nullptr));
    _exit(8);
  }
  char c;
  temp_seen = read(ready[0], &c, 1) == 1 && entries(d) == 1;
  kill(pid, sig);  // an ignored signal is dropped here; a caught one ends the child
  if (write(go[1], "x", 1) != 1) { /* the child has already ended */ }
  int status = -1;
  for (int waited = 0; waited < 1000 && waitpid(pid, &status, WNOHANG) == 0; ++waited) usleep(10000);
  if (status == -1) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
  for (int fd : {ready[0], ready[1], go[0], go[1]}) close(fd);
  return status;
}

}  // namespace

// Under both dispositions, for every signal the writer handles, whatever the test process itself inherited.
TEST(Files, ACaughtSignalRemovesTheTemporaryFileAndStillEndsTheProcess) {
  for (int sig : {SIGTERM, SIGINT, SIGHUP, SIGQUIT}) {
    Dir d;
    bool temp_seen = false;
    const int status = signalled_child(d, sig, SIG_DFL, temp_seen);
    EXPECT_TRUE(temp_seen) << "signal " << sig;  // the temporary file exists while it writes
    EXPECT_TRUE(status != -1 && WIFSIGNALED(status) && WTERMSIG(status) == sig) << "signal " << sig << ": " << status;
    EXPECT_EQ(entries(d), 0u) << "signal " << sig;
  }
}

TEST(Files, ASignalIgnoredAtTheStartStaysIgnoredAndTheOutputIsWritten) {
  for (int sig : {SIGTERM, SIGINT, SIGHUP, SIGQUIT}) {
    Dir d;
    bool temp_seen = false;
    const int status = signalled_child(d, sig, SIG_IGN, temp_seen);
    EXPECT_TRUE(temp_seen) << "signal " << sig;
    EXPECT_TRUE(status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0) << "signal " << sig << ": " << status;
    EXPECT_EQ(get(d / "out.png"), "whole") << "signal " << sig;
    EXPECT_EQ(entries(d), 1u) << "signal " << sig;
  }
}

TEST(Files, NoHandlerIsLeftOnceNoTemporaryFileExists) {
  struct sigaction before {}, during {}, after {};
  sigaction(SIGTERM, nullptr, &before);
  Dir d;
  {
    AtomicFile f(d / "x.png");
    sigaction(SIGTERM, nullptr, &during);
    if (before.sa_handler != SIG_IGN) {
      EXPECT_NE(during.sa_handler, before.sa_handler);
    }
    f.commit();
  }
  sigaction(SIGTERM, nullptr, &after);
  EXPECT_EQ(after.sa_handler, before.sa_handler);
}

TEST(Files, InputsMustBeRegularFiles) {
  Dir d;
  ASSERT_EQ(mkfifo((d / "fifo").c_str(), 0644), 0);
  try {
    hpcgi::files::require_input(d / "fifo", "--ff");
    FAIL() << "a FIFO was accepted";
  } catch (const hpcgi::UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("is a FIFO, not a file"), std::string::npos);
  }
  EXPECT_THROW(hpcgi::files::require_input(d.p.string(), "--ff"), hpcgi::UsageError);
  put(d / "x.ff", "x");
  EXPECT_NO_THROW(hpcgi::files::require_input(d / "x.ff", "--ff"));
  EXPECT_NO_THROW(hpcgi::files::require_input(d / "missing.ff", "--ff"));  // the loader says "cannot open"
}
