// bin/poisson's configuration, parsed once into enums (parse_*: the options' strings, once, where main reads them),
// printed and recorded by the same names (to_string), so that the records keep the strings they always had; the
// table of backends (backends(): one row of named facts per backend, the facts --list-backends prints); and the
// one place a configuration is refused (check_config).
#pragma once
#include <string>
#include <vector>

namespace poisson {

enum class Backend { serial, openmp, mpi, cublas1, cublas2, cuda };
enum class Variant { classic, onesweep };    // kernels.hpp: 11 or 6 vectors per iteration
enum class Precond { none, mg };             // mg: CG preconditioned by one multigrid V-cycle (mg.hpp)
enum class Method { cg, fmg };               // fmg: full multigrid, then V-cycles (mg.hpp fmg, cg.hpp run_fmg)
enum class Halo { nonblocking, blocking };   // mpi: MPI_Isend/Irecv or MPI_Send/Recv
enum class Precision { single, double_ };    // float | double: vectors and stencil (dots accumulate in double)

// The names of each choice in the enum's order, as the options, the records and the errors spell them.
template <class E>
const std::vector<std::string>& choice_names();
template <> const std::vector<std::string>& choice_names<Backend>();
template <> const std::vector<std::string>& choice_names<Variant>();
template <> const std::vector<std::string>& choice_names<Precond>();
template <> const std::vector<std::string>& choice_names<Method>();
template <> const std::vector<std::string>& choice_names<Halo>();
template <> const std::vector<std::string>& choice_names<Precision>();

// Throw hpcgi::UsageError for a name not listed ("unknown backend 'x' (see --help for the list)").
Backend parse_backend(const std::string& name);
Variant parse_variant(const std::string& name);
Precond parse_precond(const std::string& name);
Method parse_method(const std::string& name);
Halo parse_halo(const std::string& name);
Precision parse_precision(const std::string& name);

const std::string& to_string(Backend b);
const std::string& to_string(Variant v);
const std::string& to_string(Precond p);
const std::string& to_string(Method m);
const std::string& to_string(Halo h);
const std::string& to_string(Precision p);

struct Config {
  long n = 512;
  Backend backend = Backend::serial;
  Halo halo = Halo::nonblocking;
  int threads = 0;  // 0: the OpenMP default (OMP_NUM_THREADS or all cores)
  Variant variant = Variant::classic;
  Precond precond = Precond::none;
  Method method = Method::cg;
  Precision precision = Precision::double_;
  bool check_symmetry = false;  // --check-symmetry: compare (M^-1 x).y with x.(M^-1 y) before the solve (mg.hpp)
  // Whether the backend holds z and the multigrid hierarchy: for --precond mg and for --method fmg.
  bool multigrid() const { return precond == Precond::mg || method == Method::fmg; }
};

// Vectors of N² values one plain CG iteration streams (the data-movement model, kernels.hpp), by backend and
// variant: the backends' vectors_per_iteration() return these (with --precond none, --method cg).
inline constexpr int kVectorsClassic = 11;   // openmp, mpi, cuda: three fused kernels
inline constexpr int kVectorsOneSweep = 6;   // openmp, mpi, cuda: Chronopoulos-Gear in one pass
inline constexpr int kVectorsSerial = 13;    // the frozen reference: one loop per operation
inline constexpr int kVectorsCublas1 = 14;   // own stencil and axpby kernels, cuBLAS dots
inline constexpr int kVectorsCublas2 = 16;   // cuBLAS for every vector operation

// The iteration limit with --tol when --max-iter is not given: max(floor, per_n N).
struct IterLimit {
  long floor = 1000, per_n = 4;
  long of(long n) const { return n * per_n > floor ? n * per_n : floor; }
};
inline constexpr IterLimit kDefaultMaxIter{};

// One row of the table of backends: every fact the program and --list-backends state about a backend.
struct BackendEntry {
  Backend id;
  std::string summary;
  bool gpu = false;         // runs on an NVIDIA GPU (CUDA)
  bool onesweep = false;    // runs --variant onesweep (and uses it by default in double)
  bool multigrid = false;   // runs --precond mg and --method fmg
  bool cublas = false;      // calls cuBLAS (--list-backends: "libraries"; the GPU kit skips it where cuBLAS is not)
  int vectors_classic = 0;  // vectors per plain CG iteration, variant classic
  int vectors_onesweep = 0; // and variant onesweep (0: the backend has no onesweep)
  bool built = false;       // compiled into this binary
  std::string why_not;      // why not, when not built
  const std::string& name() const { return to_string(id); }
};
const std::vector<BackendEntry>& backends();
const BackendEntry& backend_entry(Backend b);

// The variant a backend runs when none is asked for: onesweep in double where the backend has it (6 vectors
// instead of 11, the same iterations and solution), classic elsewhere. In float, onesweep's recurrence for p·Ap
// loses accuracy as the float vectors lose conjugacy: it takes 10-25% more iterations (N = 128..512), so float
// keeps classic. With a preconditioner it is classic (preconditioned CG has the classic shape); with method fmg
// too (the variant does not apply, and the record says classic).
Variant default_variant(Backend b, Precision p, Precond pc = Precond::none, Method m = Method::cg);

// The one place a configuration is refused (hpcgi::UsageError, one line): a backend not built in this binary, a
// variant, preconditioner or method it does not run, --method fmg with --precond or --variant, --precond mg with
// onesweep, --check-symmetry without --precond mg, a one-process backend under mpirun with several ranks.
void check_config(const Config& cfg);

// --list-backends: the table above, as text or (json) as one JSON object (list_backends.cpp).
std::string describe_backends(bool json);

}  // namespace poisson
