// The files a run reads and writes, safe against careless and hostile paths (every program and writer uses these).
//
// Inputs must be regular files: a FIFO would block the run for ever, a device or a folder is no input.
// Outputs are checked before any computation (check_outputs) and written through AtomicFile:
//   - an output must be a regular file or a new name in an existing, writable folder: a device node, FIFO, socket
//     or folder is refused, never replaced (`--png /dev/null` must not delete /dev/null);
//   - a symbolic link is written THROUGH: the file it points to is replaced, the link stays (a dangling link is
//     refused);
//   - an output that is one of the run's inputs, or another output of the same run, is refused;
//   - the data go to a unique temporary file in the target's folder (mkstemp, O_EXCL: never a fixed FILE.tmp, so
//     an unrelated FILE.tmp is left alone and two runs writing the same output never share one), which is renamed
//     over the target only when whole (fsync first): a reader sees the old file or the new one, and of two runs
//     writing one output the file holds one whole run's data;
//   - the temporary file is removed on every error, when the AtomicFile is destroyed uncommitted, and on a signal
//     that ends the process (SIGINT, SIGTERM, SIGHUP, ...: the handler removes it, then ends the process with that
//     signal as before). A signal that was ignored when the first temporary file appeared stays ignored (nohup, a
//     script's background job): the run goes on and writes its output (coreutils' rule).
// Records are appended to a log (common/record.hpp), not replaced: check_outputs makes their folders and checks
// that the file is a regular one.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

namespace hpcgi::files {

// Throws UsageError "<what> 'PATH': ..." unless path names an existing regular file (a symlink to one is fine).
void require_input(const std::string& path, const std::string& what);

struct Output {
  std::string path;     // empty: not asked for
  std::string what;     // the option that names it, for messages ("--png")
  bool append = false;  // a record log: appended to, its folders made
};

// Every output of a run against the rules above, before anything is computed; `inputs` are the run's input files.
// Throws UsageError with one line naming the option and the reason.
void check_outputs(const std::vector<Output>& outputs, const std::vector<std::string>& inputs);

// Where a write to `path` lands: path itself, or the file a symbolic link (chain) points to.
std::string resolve_target(const std::string& path);

// One output being written. The constructor creates the temporary file beside the target; stream() is where the
// data go; commit() flushes, syncs, closes and renames it over the target. Throws std::runtime_error (with the
// reason) on any failure, after removing the temporary file.
class AtomicFile {
 public:
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::FILE* stream() { return f_; }
  const std::string& temp_path() const { return tmp_; }
  void commit();
  // Removes the temporary file and throws runtime_error "cannot write PATH: REASON".
  [[noreturn]] void fail(const std::string& reason);

 private:
  std::string path_, target_, tmp_;
  std::FILE* f_ = nullptr;
  int slot_ = -1;
  bool done_ = false;
};

// A unique temporary name for `path` created on disk (empty, mode 0644), registered for removal on a signal (above)
// until released: for writers that cannot use a FILE* (MPI-IO opens it by name on every rank). Returns the name.
std::string make_temp_beside(const std::string& path, int& slot);
void release_temp(int slot);

}  // namespace hpcgi::files
