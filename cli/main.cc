// meshstream: the command-line tool of the meshstream asset pipeline.
// No exception ever leaves main: the last catch prints one line and exits 1.
#include <exception>

#include "cli/app.h"
#include "cli/exit_codes.h"

int main(int argc, char** argv) {
  try {
    return meshstream::cli::Main(argc, argv);
  } catch (const std::exception& e) {
    return meshstream::cli::ReportInternalError(e.what());
  } catch (...) {
    return meshstream::cli::ReportInternalError("unknown exception");
  }
}
