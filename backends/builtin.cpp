// The list of backends compiled into this build; the only file above the backends that knows them.
#include "porta/registry.hpp"

namespace porta {

void register_cpu_backend(BackendRegistry& registry);
#if PORTA_HAVE_CUDA
void register_cuda_backend(BackendRegistry& registry);
#endif
#if PORTA_HAVE_VULKAN
void register_vulkan_backend(BackendRegistry& registry);
#endif
#if PORTA_HAVE_OPENCL
void register_opencl_backend(BackendRegistry& registry);
#endif

namespace {
void register_builtin_backends(BackendRegistry& registry) {
  register_cpu_backend(registry);
#if PORTA_HAVE_CUDA
  register_cuda_backend(registry);
#endif
#if PORTA_HAVE_VULKAN
  register_vulkan_backend(registry);
#endif
#if PORTA_HAVE_OPENCL
  register_opencl_backend(registry);
#endif
}
}  // namespace

BackendRegistry& BackendRegistry::instance() {
  static BackendRegistry registry = [] {
    BackendRegistry r;
    register_builtin_backends(r);
    return r;
  }();
  return registry;
}

}  // namespace porta
