// Asking a device backend for a device that does not exist is a clear error, never a crash: the
// message names the backend and what was asked for (and, where a driver is present, the devices
// found). Runs for every device backend compiled into this build.
#include <gtest/gtest.h>

#include <string>

#include "porta/registry.hpp"

namespace porta {
namespace {

class DeviceSelection : public ::testing::TestWithParam<std::string> {};

TEST_P(DeviceSelection, AMissingDeviceIsAClearErrorNamingTheBackend) {
  const std::string name = GetParam();
  BackendInfo info;
  for (const auto& i : BackendRegistry::instance().list())
    if (i.name == name) info = i;
  if (!info.compiled) GTEST_SKIP() << name << " is not built into this binary: " << info.detail;
  for (const std::string device : {"no-such-device-xyz", "99"}) {
    BackendOptions options;
    options.device = device;
    try {
      BackendRegistry::instance().create(name, options);
      FAIL() << name << " accepted device '" << device << "'";
    } catch (const BackendError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(name + ":", 0), 0u) << what;  // "<backend>: ..." first
      if (info.available) {
        EXPECT_NE(what.find(device), std::string::npos) << what;
        EXPECT_NE(what.find("found"), std::string::npos) << "the devices found should be listed: " << what;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(DeviceBackends, DeviceSelection, ::testing::Values("opencl", "vulkan", "cuda"),
                         [](const auto& p) { return p.param; });

}  // namespace
}  // namespace porta
