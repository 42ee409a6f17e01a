#include "common/cli.hpp"

#include <cstdio>
#include <exception>

#include "common/comm.hpp"
#include "common/errors.hpp"
#include "common/memory.hpp"

namespace hpcgi {

bool parse_cli(CLI::App& app, int argc, char** argv, int& exit_code) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    exit_code = app.exit(e);  // prints the help on stdout, returns 0
    return false;
  } catch (const CLI::CallForAllHelp& e) {
    exit_code = app.exit(e);
    return false;
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: %s (see --help)\n", app.get_name().c_str(), e.what());
    exit_code = kExitUsage;
    return false;
  }
  return true;
}

CLI::Validator byte_size() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          parse_bytes(s);
        } catch (const UsageError& e) {
          return e.what();
        }
        return {};
      },
      "BYTES");
}

namespace {

// One line on stderr. Of several MPI ranks, an error they agreed on is reported by rank 0 alone; an error of one
// rank is reported with its rank and ends every rank, as the others may be waiting for it in a collective.
int report(const std::string& program, const std::exception& e, const char* kind, int status) {
  const bool agreed = dynamic_cast<const AgreedError*>(&e) != nullptr;
  if (comm::size() > 1 && !agreed) {
    std::fprintf(stderr, "%s: rank %d of %d: %s%s\n", program.c_str(), comm::rank(), comm::size(), kind, e.what());
    std::fflush(stderr);
    comm::abort(status);
  }
  if (comm::root()) std::fprintf(stderr, "%s: %s%s\n", program.c_str(), kind, e.what());
  return status;
}

}  // namespace

int run_main(const std::string& program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    return report(program, e, "", kExitUsage);
  } catch (const NumericalError& e) {
    return report(program, e, "numerical failure: ", kExitNumerical);
  } catch (const std::exception& e) {
    return report(program, e, "error: ", kExitRuntime);
  }
}

}  // namespace hpcgi
