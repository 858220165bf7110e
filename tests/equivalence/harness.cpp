#include "equivalence/harness.hpp"

#include <algorithm>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <sstream>

#include "equivalence/inputs.hpp"
#include "porta/registry.hpp"

namespace porta::eq {

namespace {

std::vector<std::string> split_list(const char* text) {
  std::vector<std::string> out;
  std::string item;
  for (const char* p = text; p != nullptr && *p != '\0'; ++p) {
    if (*p == ',' || *p == ' ') {
      if (!item.empty()) out.push_back(item);
      item.clear();
    } else {
      item += *p;
    }
  }
  if (!item.empty()) out.push_back(item);
  return out;
}

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' && std::string(v) != "0";
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

/// Every backend the harness can put under test, in registry order, then the self-test one.
std::vector<std::string> candidate_backends() {
  std::vector<std::string> all;
  for (const auto& n : known_backend_names())
    if (n != "cpu") all.push_back(n);
  all.push_back(kSelfTestBackend);
  return all;
}

// ---- Summary state -------------------------------------------------------------------------------

struct Tally {
  int pass = 0, fail = 0, skip_input = 0, not_run = 0;
  double seconds = 0;
};
std::map<std::pair<std::string, std::string>, Tally>& tallies() {
  static std::map<std::pair<std::string, std::string>, Tally> t;
  return t;
}
struct Current {
  bool active = false;
  std::string kernel, backend;
  bool not_run = false;
  bool input_skip = false;
};
Current& current() {
  static Current c;
  return c;
}

std::map<std::string, BackendSlot>& slots() {
  static std::map<std::string, BackendSlot> s;
  return s;
}

}  // namespace

void release_backends() {
  for (auto& [name, slot] : slots()) slot.backend.reset();
}

namespace {

class SummaryListener : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    Current& c = current();
    if (!c.active) return;
    Tally& t = tallies()[{c.kernel, c.backend}];
    const ::testing::TestResult& r = *info.result();
    if (r.Failed())
      ++t.fail;
    else if (r.Skipped())
      ++(c.not_run ? t.not_run : t.skip_input);
    else
      ++t.pass;
    t.seconds += static_cast<double>(r.elapsed_time()) / 1000.0;
    c = Current{};
  }
};

std::string cell_text(const Tally& t) {
  const int ran = t.pass + t.fail;
  std::string s;
  if (ran == 0) {
    if (t.not_run > 0) return "not run";
    if (t.skip_input > 0) return "skipped " + std::to_string(t.skip_input);
    return "-";
  }
  s = t.fail > 0 ? "FAIL " + std::to_string(t.fail) + "/" + std::to_string(ran)
                 : "pass " + std::to_string(t.pass);
  if (t.skip_input > 0) s += ", skip " + std::to_string(t.skip_input);
  return s;
}

}  // namespace

// ---- Backends ------------------------------------------------------------------------------------

const std::vector<std::string>& backends_under_test() {
  static const std::vector<std::string> list = [] {
    const std::vector<std::string> only = split_list(std::getenv("PORTA_EQUIVALENCE_BACKENDS"));
    const bool selftest = env_flag("PORTA_EQUIVALENCE_SELFTEST");
    std::vector<std::string> out;
    for (const auto& n : candidate_backends()) {
      if (!only.empty() ? contains(only, n) : (n != kSelfTestBackend || selftest)) out.push_back(n);
    }
    return out;
  }();
  return list;
}

std::string backend_selection_error() {
  const auto candidates = candidate_backends();
  for (const auto& n : split_list(std::getenv("PORTA_EQUIVALENCE_BACKENDS"))) {
    if (n == "cpu")
      return "PORTA_EQUIVALENCE_BACKENDS names cpu, the reference; to compare cpu with itself use " +
             std::string(kSelfTestBackend) + " (or PORTA_EQUIVALENCE_SELFTEST=1)";
    if (!contains(candidates, n)) {
      std::string known;
      for (const auto& c : candidates) known += (known.empty() ? "" : ", ") + c;
      return "PORTA_EQUIVALENCE_BACKENDS names '" + n + "', which is not a backend; choose among " + known;
    }
  }
  return {};
}

Backend& reference_backend() {
  static const std::unique_ptr<Backend> cpu = BackendRegistry::instance().create("cpu");
  return *cpu;
}

BackendSlot& backend_slot(const std::string& name) {
  auto it = slots().find(name);
  if (it != slots().end()) return it->second;
  BackendSlot slot;
  slot.name = name;
  try {
    if (name == kSelfTestBackend) {
      BackendOptions one_thread;
      one_thread.threads = 1;
      slot.backend = BackendRegistry::instance().create("cpu", one_thread);
      slot.detail = "cpu with 1 thread, checked against cpu: the harness self-test";
      slot.present = true;
    } else {
      BackendInfo info{name, false, false, "not known to the registry"};
      for (const BackendInfo& i : BackendRegistry::instance().list())
        if (i.name == name) info = i;
      if (!info.compiled) {
        slot.detail = info.detail;
      } else if (!info.available) {
        slot.detail = "no usable device: " + info.detail;
      } else {
        slot.backend = BackendRegistry::instance().create(name);
        slot.detail = slot.backend->device_name();
        slot.present = true;
      }
    }
  } catch (const std::exception& e) {
    slot.creation_failed = true;
    slot.present = false;
    slot.backend.reset();
    slot.detail = std::string("creating it failed: ") + e.what();
  }
  return slots().emplace(name, std::move(slot)).first->second;
}

// ---- Summary -------------------------------------------------------------------------------------

const std::vector<std::string>& summary_kernels() {
  static const std::vector<std::string> k = {
      "rectify", "build_pyramid", "fast_crf",     "cull_cells",   "pfa_filter",       "compact_keypoints",
      "orient",  "blur",          "orb_describe", "stereo_match", "projection_match", "frontend"};
  return k;
}

void install_summary_listener() {
  ::testing::UnitTest::GetInstance()->listeners().Append(new SummaryListener);  // gtest takes ownership
}

std::string summary_table() {
  const auto& backends = backends_under_test();
  std::ostringstream o;
  o << "| kernel |";
  for (const auto& b : backends) o << " " << b << " |";
  o << "\n|---|";
  for (std::size_t i = 0; i < backends.size(); ++i) o << "---|";
  o << "\n";
  std::map<std::string, Tally> totals;
  for (const auto& k : summary_kernels()) {
    o << "| " << k << " |";
    for (const auto& b : backends) {
      const Tally t = tallies()[{k, b}];
      Tally& total = totals[b];
      total.pass += t.pass;
      total.fail += t.fail;
      total.skip_input += t.skip_input;
      total.not_run += t.not_run;
      total.seconds += t.seconds;
      o << " " << cell_text(t) << " |";
    }
    o << "\n";
  }
  o << "| **all** |";
  for (const auto& b : backends) o << " **" << cell_text(totals[b]) << "** |";
  o << "\n\nreference: cpu, " << reference_backend().device_name() << "\n";
  for (const auto& b : backends) {
    const auto it = slots().find(b);
    const Tally& t = totals[b];
    o << "- " << b << ": ";
    if (it == slots().end())
      o << "no case selected";
    else if (it->second.present)
      o << it->second.detail << "; " << t.pass + t.fail << " cases in " << std::fixed << std::setprecision(1)
        << t.seconds << " s";
    else
      o << (it->second.creation_failed ? "FAILED: " : "not run: ") << it->second.detail;
    o << "\n";
  }
  return o.str();
}

std::vector<std::string> required_backends_not_run() {
  std::vector<std::string> out;
  const auto under_test = backends_under_test();
  for (const auto& name : split_list(std::getenv("PORTA_EQUIVALENCE_REQUIRE"))) {
    // A run restricted to other backends (one ctest entry per backend) does not owe this one.
    if (std::find(under_test.begin(), under_test.end(), name) == under_test.end()) continue;
    const auto it = slots().find(name);
    if (it == slots().end() || !it->second.present) out.push_back(name);
  }
  return out;
}

bool any_backend_ran() {
  for (const auto& [key, t] : tallies())
    if (t.pass + t.fail > 0) return true;
  for (const auto& [name, slot] : slots())
    if (slot.creation_failed) return true;
  return false;
}

// ---- The fixture ---------------------------------------------------------------------------------

void KernelEquivalence::SetUp() {
  const KernelCase& c = GetParam();
  current() = Current{true, c.kernel, c.backend, false, false};
  BackendSlot& slot = backend_slot(c.backend);
  if (slot.creation_failed)
    FAIL() << c.backend
           << " could not be created although the registry lists it as available: " << slot.detail << "\n"
           << context();
  if (!slot.present) {
    current().not_run = true;
    GTEST_SKIP() << c.backend << " not run: " << slot.detail;
  }
  device_ = slot.backend.get();
}

void KernelEquivalence::note_input_skip() { current().input_skip = true; }

std::string KernelEquivalence::context() const {
  const KernelCase& c = GetParam();
  std::ostringstream o;
  o << "  backend: " << c.backend;
  if (device_ != nullptr) o << " (" << device_->device_name() << ")";
  o << ", reference cpu (" << reference_backend().device_name() << ")";
  for (std::size_t i = 0; i < c.inputs.size(); ++i) {
    std::string role = "input";
    if (c.kernel == "stereo_match") role = i == 0 ? "left" : "right";
    if (c.kernel == "frontend")
      role = "frame " + std::to_string(c.stereo ? i / 2 + 1 : i + 1) +
             (c.stereo ? (i % 2 ? " right" : " left") : "");
    o << "\n  " << role << ": " << describe_input(c.inputs[i]);
  }
  if (c.kernel != "rectify")
    o << "\n  settings: " << describe_settings(profiles().at(static_cast<std::size_t>(c.profile)).settings);
  if (!c.variant_label.empty()) o << "\n  variant: " << c.variant_label;
  o << "\n  test: " << ::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name() << "."
    << ::testing::UnitTest::GetInstance()->current_test_info()->name();
  return o.str();
}

void KernelEquivalence::expect_same(const std::optional<std::string>& mismatch) {
  if (mismatch)
    ADD_FAILURE() << GetParam().kernel << " on " << GetParam().backend << " differs from cpu\n"
                  << context() << "\n  " << *mismatch;
}

void KernelEquivalence::debug_corrupt(void* bytes, std::size_t size, std::size_t offset) const {
  const auto kernels = split_list(std::getenv("PORTA_EQUIVALENCE_CORRUPT"));
  if (kernels.empty() || offset >= size) return;
  if (!contains(kernels, "all") && !contains(kernels, GetParam().kernel)) return;
  static_cast<std::uint8_t*>(bytes)[offset] ^= 1u;
}

// ---- Device helpers ------------------------------------------------------------------------------

std::unique_ptr<Buffer> upload_bytes(Backend& b, const void* data, std::size_t bytes, std::size_t capacity) {
  auto buffer = b.allocate(std::max<std::size_t>({bytes, capacity, 64}));
  if (bytes > 0) b.upload(*buffer, 0, data, bytes);
  return buffer;
}

std::unique_ptr<Buffer> poisoned(Backend& b, std::size_t bytes) {
  auto buffer = b.allocate(std::max<std::size_t>(bytes, 64));
  b.fill(*buffer, 0, buffer->size_bytes(), kPoison);
  return buffer;
}

std::vector<std::uint8_t> download_bytes(Backend& b, const Buffer& buffer, std::size_t bytes,
                                         std::size_t offset) {
  std::vector<std::uint8_t> out(bytes);
  if (bytes > 0) b.download(buffer, offset, out.data(), bytes);
  return out;
}

DeviceKeypoints upload_keypoints(Backend& b, const std::vector<Keypoint>& keypoints, int variant) {
  const bool offset_count = variant % 2 == 1;
  const int n = static_cast<int>(keypoints.size());
  const int capacity = offset_count ? n + 7 : n;
  DeviceKeypoints d = empty_keypoints(b, capacity, variant);
  if (n > 0) b.upload(*d.items, 0, keypoints.data(), keypoints.size() * sizeof(Keypoint));
  const auto count = static_cast<std::uint32_t>(n);
  b.upload(*d.count, static_cast<std::size_t>(d.list.count_offset_bytes), &count, sizeof(count));
  return d;
}

DeviceKeypoints empty_keypoints(Backend& b, int capacity, int variant) {
  const bool offset_count = variant % 2 == 1;
  DeviceKeypoints d;
  d.items = poisoned(b, static_cast<std::size_t>(capacity) * sizeof(Keypoint));
  d.count = poisoned(b, offset_count ? 16 : 4);
  d.list = DeviceList{d.items.get(), d.count.get(), offset_count ? 8 : 0, capacity};
  return d;
}

std::uint32_t download_count(Backend& b, const DeviceList& list) {
  std::uint32_t n = 0;
  b.download(*list.count, static_cast<std::size_t>(list.count_offset_bytes), &n, sizeof(n));
  return n;
}

}  // namespace porta::eq
