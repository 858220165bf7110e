// Entry point of porta_equivalence_tests: runs every case, then prints the kernel x backend summary
// (and writes it to $PORTA_EQUIVALENCE_SUMMARY when set). Exit codes: 0 all run cases passed, 1 a
// case failed or a backend of $PORTA_EQUIVALENCE_REQUIRE did not run, 2 bad environment, 77 no
// backend under test could run at all (ctest reports the test as skipped, never as passed).
// `--list-backends` prints what this build has and what this machine offers, and exits.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iostream>

#include "equivalence/harness.hpp"
#include "porta/registry.hpp"

namespace {

/// What this binary has and what this machine offers, backend by backend.
void print_registry(std::ostream& os) {
  os << "Backends of this build on this machine:\n";
  for (const porta::BackendInfo& info : porta::BackendRegistry::instance().list())
    os << "  " << info.name << ": "
       << (info.compiled ? (info.available ? "available" : "built, no device") : "not built") << " - "
       << info.detail << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  using namespace porta::eq;
  if (const std::string error = backend_selection_error(); !error.empty()) {
    std::cerr << "porta_equivalence_tests: " << error << "\n";
    return 2;
  }
  ::testing::InitGoogleTest(&argc, argv);
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--list-backends") {
      print_registry(std::cout);
      return 0;
    }
  if (::testing::GTEST_FLAG(list_tests)) return RUN_ALL_TESTS();
  install_summary_listener();

  std::cout << "PortaSLAM equivalence suite: every case compares cpu with one backend, byte for byte.\n";
  print_registry(std::cout);
  std::cout << "Backends under test:";
  for (const auto& b : backends_under_test()) std::cout << " " << b;
  std::cout << "\n";

  int status = RUN_ALL_TESTS();

  const std::string table = summary_table();
  std::cout << "\n==== equivalence summary (cases per kernel and backend) ====\n" << table;
  if (const char* path = std::getenv("PORTA_EQUIVALENCE_SUMMARY"); path != nullptr && *path != '\0') {
    std::ofstream file(path);
    file << "# PortaSLAM equivalence summary\n\n" << table;
    if (!file) {
      std::cerr << "porta_equivalence_tests: cannot write the summary to " << path << "\n";
      status = 1;
    }
  }
  release_backends();
  const auto missing = required_backends_not_run();
  for (const auto& b : missing)
    std::cout << "REQUIRED BACKEND NOT RUN: " << b << " (listed in PORTA_EQUIVALENCE_REQUIRE)\n";
  if (!missing.empty()) return 1;
  if (status == 0 && !any_backend_ran()) {
    std::cout << "No backend under test could run: nothing was compared (exit 77, reported as skipped).\n";
    return 77;
  }
  return status;
}
