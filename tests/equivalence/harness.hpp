// The cross-backend equivalence harness (DESIGN.md §5, docs/EQUIVALENCE.md): in the manner of
// ggml's test-backend-ops, every case runs one kernel (or the whole Frontend) on the cpu reference
// and on one backend under test with identical inputs, and requires identical meaningful bytes.
//
// This header holds what every case shares: the backends (each created once per process), the
// case parameter and its test name, the fixture that skips a backend that is not present (never a
// pass), device upload/download helpers, and the per-kernel x backend summary.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/keypoint.hpp"

namespace porta::eq {

// ---- Backends ------------------------------------------------------------------------------------

/// Name of the harness self-test backend: a second cpu backend with 1 thread, under test when
/// PORTA_EQUIVALENCE_SELFTEST=1 (every case must then pass).
inline constexpr const char* kSelfTestBackend = "selftest";

/// Backends whose cases are registered: every known backend except cpu (the reference), plus
/// "selftest" under PORTA_EQUIVALENCE_SELFTEST=1, restricted to PORTA_EQUIVALENCE_BACKENDS
/// (comma-separated) when that is set.
const std::vector<std::string>& backends_under_test();
/// Destroys every backend made for the run. Called before main returns: a backend destroyed during
/// static destruction may outlive its driver's own teardown (seen as a crash at exit on NVIDIA).
void release_backends();
/// Why PORTA_EQUIVALENCE_BACKENDS is invalid (an unknown name), or empty.
std::string backend_selection_error();

/// A backend under test, created on first use and kept for the whole run.
struct BackendSlot {
  std::string name;
  bool present = false;          ///< created: its cases run
  bool creation_failed = false;  ///< the registry said available but creating it threw: a failure
  std::string detail;            ///< the device in words, or why the backend is not run
  std::unique_ptr<Backend> backend;
};
BackendSlot& backend_slot(const std::string& name);
/// The cpu backend every result is compared with (all hardware threads).
Backend& reference_backend();

// ---- Cases ---------------------------------------------------------------------------------------

/// One case: a kernel on a backend for some inputs and settings.
struct KernelCase {
  std::string kernel;               ///< "fast_crf", ..., or "frontend"
  std::string backend;              ///< the backend under test
  std::vector<std::string> inputs;  ///< image names (inputs.hpp); meaning depends on the kernel
  int profile = 0;                  ///< index into profiles()
  int variant = 0;                  ///< kernel-specific variation (map, query set, list layout)
  std::string variant_label;        ///< names the variant in the test name, may be empty
  bool stereo = false;              ///< frontend: inputs are (left, right) pairs per frame
};
void PrintTo(const KernelCase& c, std::ostream* os);
/// Test name: <backend>_<inputs>_<settings label>[_<variant>], identifier characters only.
std::string case_name(const ::testing::TestParamInfo<KernelCase>& info);
/// The kernel's cases crossed with backends_under_test() (cases.cpp holds the covering design).
std::vector<KernelCase> cases_for(const std::string& kernel);

// ---- Summary -------------------------------------------------------------------------------------

/// The kernels in the order of the summary table (backend.hpp order, then "frontend").
const std::vector<std::string>& summary_kernels();
/// Installs the listener that counts outcomes per kernel and backend.
void install_summary_listener();
/// The summary as a Markdown table with a line per backend below it.
std::string summary_table();
/// Backends listed in PORTA_EQUIVALENCE_REQUIRE that did not run, or failed to be created.
std::vector<std::string> required_backends_not_run();
/// True when at least one case of a backend under test ran (passed or failed).
bool any_backend_ran();

// ---- The fixture ---------------------------------------------------------------------------------

class KernelEquivalence : public ::testing::TestWithParam<KernelCase> {
 protected:
  /// Skips (GTEST_SKIP, reported as "not run") when the backend is not built or has no device;
  /// fails when it should be available but cannot be created.
  void SetUp() override;

  Backend& cpu() { return reference_backend(); }
  Backend& device() { return *device_; }
  const std::string& backend_name() const { return GetParam().backend; }

  /// The indented lines of a failure report after its headline: backend and device, inputs,
  /// settings, variant, and the test's full name (for --gtest_filter).
  std::string context() const;
  /// Records the input as the reason for a skip (the summary counts it apart from "not run").
  static void note_input_skip();

  /// Runs `fn(backend)` on cpu and then on the backend under test. When either throws, adds a
  /// failure naming the case and the exception and returns nullopt.
  template <typename Fn>
  auto run_both(Fn&& fn)
      -> std::optional<std::pair<std::invoke_result_t<Fn&, Backend&>, std::invoke_result_t<Fn&, Backend&>>> {
    using R = std::invoke_result_t<Fn&, Backend&>;
    std::optional<R> ref, got;
    if (!guarded(cpu(), [&] { ref.emplace(fn(cpu())); })) return std::nullopt;
    if (!guarded(device(), [&] { got.emplace(fn(device())); })) return std::nullopt;
    return std::make_pair(std::move(*ref), std::move(*got));
  }

  /// Adds a failure with the context when `mismatch` holds a description.
  void expect_same(const std::optional<std::string>& mismatch);

  /// Under PORTA_EQUIVALENCE_CORRUPT=<kernel>|all, flips bit 0 of `bytes[offset]` of the backend's
  /// output, so that the failure report can be seen without breaking a kernel.
  void debug_corrupt(void* bytes, std::size_t size, std::size_t offset) const;

 private:
  template <typename Body>
  bool guarded(Backend& b, Body&& body) {
    try {
      body();
      return true;
    } catch (const std::exception& e) {
      ADD_FAILURE() << GetParam().kernel << " on " << GetParam().backend << ": " << b.name()
                    << " threw: " << e.what() << "\n"
                    << context();
      return false;
    }
  }
  Backend* device_ = nullptr;
};

/// In a test body: `var` = the scene of (input, profile); skips the case (counted as an input skip,
/// not as "not run") when the image cannot be had.
#define PORTA_EQ_SCENE_OR_SKIP(var, input, profile)                       \
  std::string var##_why;                                                  \
  const auto var = ::porta::eq::scene_for((input), (profile), var##_why); \
  if (!var) {                                                             \
    note_input_skip();                                                    \
    GTEST_SKIP() << var##_why;                                            \
  }

// ---- Device helpers ------------------------------------------------------------------------------

/// A byte value no kernel output should keep: output buffers are filled with it first, so a
/// backend that leaves a meaningful element unwritten differs from cpu.
inline constexpr std::uint8_t kPoison = 0xA5;

/// A buffer of `bytes` (at least 64, as devices reject empty buffers) holding `data`.
std::unique_ptr<Buffer> upload_bytes(Backend& b, const void* data, std::size_t bytes,
                                     std::size_t capacity = 0);
template <typename T>
std::unique_ptr<Buffer> upload_vector(Backend& b, const std::vector<T>& v, std::size_t capacity_elems = 0) {
  return upload_bytes(b, v.data(), v.size() * sizeof(T), capacity_elems * sizeof(T));
}
/// A buffer of `bytes` (at least 64) filled with kPoison.
std::unique_ptr<Buffer> poisoned(Backend& b, std::size_t bytes);
std::vector<std::uint8_t> download_bytes(Backend& b, const Buffer& buffer, std::size_t bytes,
                                         std::size_t offset = 0);
template <typename T>
std::vector<T> download_vector(Backend& b, const Buffer& buffer, std::size_t count, std::size_t offset = 0) {
  std::vector<T> out(count);
  if (count > 0) b.download(buffer, offset, out.data(), count * sizeof(T));
  return out;
}

/// A device keypoint list. Odd `variant`s put the count at byte 8 of a 16-byte buffer (exercising
/// count_offset_bytes) and leave spare capacity; even ones use a 4-byte count at 0 and exact capacity.
struct DeviceKeypoints {
  std::unique_ptr<Buffer> items, count;
  DeviceList list;
};
DeviceKeypoints upload_keypoints(Backend& b, const std::vector<Keypoint>& keypoints, int variant);
/// An empty list (count poisoned) with room for `capacity` records, laid out like upload_keypoints.
DeviceKeypoints empty_keypoints(Backend& b, int capacity, int variant);
std::uint32_t download_count(Backend& b, const DeviceList& list);

}  // namespace porta::eq
