#include "common/cli.hpp"

#include <cstdio>
#include <exception>

#include "common/errors.hpp"

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

int run_main(const std::string& program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), e.what());
    return kExitUsage;
  } catch (const NumericalError& e) {
    std::fprintf(stderr, "%s: numerical failure: %s\n", program.c_str(), e.what());
    return kExitNumerical;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program.c_str(), e.what());
    return kExitRuntime;
  }
}

}  // namespace hpcgi
