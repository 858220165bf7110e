// Pipelines and descriptor sets of the Vulkan backend: each kernel's pipeline is created on its
// first dispatch from the embedded SPIR-V, with a layout read from the module itself (a minimal
// reflection: set-0 storage buffers, a push-constant block or a set-1 parameter buffer, the local
// size), so that a shader and its host call cannot disagree silently. Descriptor sets are cached
// by the buffers they bind.
#include <algorithm>
#include <cstring>
#include <set>
#include <string>

#include "vulkan/embedded_spirv.hpp"
#include "vulkan/vk_errors.hpp"
#include "vulkan/vk_runtime.hpp"

namespace porta::vulkan {

namespace {

constexpr std::uint32_t kSetsPerPool = 256;
constexpr std::uint32_t kBuffersPerPool = kSetsPerPool * 8;

/// What a compute module declares, as far as the runtime needs it.
struct Reflection {
  std::uint32_t bindings = 0;
  std::uint32_t written = 0;  ///< set-0 bindings the shader may write (not NonWritable), one bit each
  bool push = false;
  bool params_buffer = false;
  std::uint32_t local[3] = {0, 0, 0};
};

// SPIR-V opcodes, decorations and storage classes used below (SPIR-V spec, section 3).
constexpr std::uint32_t kSpirvMagic = 0x07230203;
constexpr std::uint32_t kOpExecutionMode = 16, kOpTypeStruct = 30, kOpTypePointer = 32, kOpVariable = 59,
                        kOpDecorate = 71, kOpMemberDecorate = 72;
constexpr std::uint32_t kExecutionModeLocalSize = 17;
constexpr std::uint32_t kDecorationNonWritable = 24, kDecorationBinding = 33, kDecorationDescriptorSet = 34;
constexpr std::uint32_t kStorageUniform = 2, kStoragePushConstant = 9, kStorageStorageBuffer = 12;

Reflection reflect(const EmbeddedSpirv& module) {
  const std::string where = std::string("vulkan: shader ") + module.name + ": ";
  const std::uint32_t* w = module.words;
  const std::size_t n = module.word_count;
  if (n < 5 || w[0] != kSpirvMagic) throw BackendError(where + "the embedded module is not SPIR-V");
  Reflection r;
  std::map<std::uint32_t, std::uint32_t> set_of, binding_of;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> variables;  // (id, storage class)
  // Whether a buffer is read-only: NonWritable on the variable, or on every member of its block
  // (glslang decorates a `readonly buffer`'s members).
  std::map<std::uint32_t, std::uint32_t> type_of, pointee_of, members_of;  // variable, pointer, struct
  std::map<std::uint32_t, std::set<std::uint32_t>> nonwritable_members;
  std::set<std::uint32_t> nonwritable;
  for (std::size_t i = 5; i < n;) {
    const std::uint32_t op = w[i] & 0xFFFFu, count = w[i] >> 16;
    if (count == 0 || i + count > n)
      throw BackendError(where + "malformed SPIR-V at word " + std::to_string(i));
    if (op == kOpExecutionMode && count >= 6 && w[i + 2] == kExecutionModeLocalSize) {
      r.local[0] = w[i + 3];
      r.local[1] = w[i + 4];
      r.local[2] = w[i + 5];
    } else if (op == kOpDecorate && count >= 3) {
      if (count >= 4 && w[i + 2] == kDecorationDescriptorSet) set_of[w[i + 1]] = w[i + 3];
      if (count >= 4 && w[i + 2] == kDecorationBinding) binding_of[w[i + 1]] = w[i + 3];
      if (w[i + 2] == kDecorationNonWritable) nonwritable.insert(w[i + 1]);
    } else if (op == kOpMemberDecorate && count >= 4 && w[i + 3] == kDecorationNonWritable) {
      nonwritable_members[w[i + 1]].insert(w[i + 2]);
    } else if (op == kOpTypeStruct && count >= 2) {
      members_of[w[i + 1]] = count - 2;
    } else if (op == kOpTypePointer && count >= 4) {
      pointee_of[w[i + 1]] = w[i + 3];
    } else if (op == kOpVariable && count >= 4) {
      variables.emplace_back(w[i + 2], w[i + 3]);
      type_of[w[i + 2]] = w[i + 1];
    }
    i += count;
  }
  std::set<std::uint32_t> set0;
  for (const auto& [id, storage] : variables) {
    if (storage == kStoragePushConstant) {
      r.push = true;
    } else if (storage == kStorageStorageBuffer || storage == kStorageUniform) {
      const std::uint32_t set = set_of.count(id) ? set_of[id] : 0;
      const std::uint32_t binding = binding_of.count(id) ? binding_of[id] : 0;
      if (set == 0) {
        set0.insert(binding);
        const std::uint32_t block = pointee_of.count(type_of[id]) ? pointee_of[type_of[id]] : 0;
        const bool read_only = nonwritable.count(id) > 0 || nonwritable.count(block) > 0 ||
                               (members_of.count(block) > 0 && members_of[block] > 0 &&
                                nonwritable_members[block].size() == members_of[block]);
        if (binding >= 32) throw BackendError(where + "binds more than 32 buffers");
        if (!read_only) r.written |= 1u << binding;
      } else if (set == 1 && binding == 0) {
        r.params_buffer = true;
      } else {
        throw BackendError(where + "declares a buffer at set " + std::to_string(set) + ", binding " +
                           std::to_string(binding) +
                           "; kernels use set 0 (buffers) and set 1 binding 0 (parameters)");
      }
    }
  }
  r.bindings = static_cast<std::uint32_t>(set0.size());
  if (!set0.empty() && *set0.rbegin() != r.bindings - 1)
    throw BackendError(where + "set-0 bindings must be 0.." + std::to_string(r.bindings - 1) +
                       " without gaps");
  if (r.local[0] == 0)
    throw BackendError(where + "declares no literal local size (layout(local_size_x = ...) in;)");
  return r;
}

const EmbeddedSpirv* find_module(const char* name) {
  for (int i = 0; i < kEmbeddedSpirvCount; ++i)
    if (std::strcmp(kEmbeddedSpirv[i].name, name) == 0) return &kEmbeddedSpirv[i];
  return nullptr;
}

std::uint64_t ceil_div(std::uint64_t a, std::uint64_t b) { return (a + b - 1) / b; }

}  // namespace

Runtime::Kernel& Runtime::kernel(const char* name, std::uint32_t params_bytes) {
  if (auto it = kernels_.find(name); it != kernels_.end()) {
    if (it->second->params_bytes != params_bytes)
      throw BackendError(std::string("vulkan: ") + name + ": dispatched with " +
                         std::to_string(params_bytes) + " parameter bytes, earlier with " +
                         std::to_string(it->second->params_bytes));
    return *it->second;
  }
  const EmbeddedSpirv* module = find_module(name);
  if (module == nullptr)
    throw BackendError(std::string("vulkan: no embedded shader '") + name + "' (shaders/vulkan/" + name +
                       ".comp)");
  const Reflection r = reflect(*module);
  const std::string where = std::string("vulkan: ") + name + ": ";
  if (r.push && r.params_buffer)
    throw BackendError(where +
                       "the shader declares both a push-constant block and a parameter buffer; use one");
  if (params_bytes > 0 && !r.push && !r.params_buffer)
    throw BackendError(where + "the host passes " + std::to_string(params_bytes) +
                       " parameter bytes but the shader declares no parameter block");
  const std::uint32_t push_limit = std::min(kMaxPushBytes, ctx_->limits().maxPushConstantsSize);
  if (r.push && params_bytes > push_limit)
    throw BackendError(where + "the host passes " + std::to_string(params_bytes) +
                       " parameter bytes, more than a push-constant block holds (" +
                       std::to_string(push_limit) +
                       "): declare them as `layout(std430, set = 1, binding = 0) readonly buffer`");
  if (r.params_buffer && params_bytes > kMaxParamsBytes)
    throw BackendError(where + "the host passes " + std::to_string(params_bytes) +
                       " parameter bytes, more than the parameter buffer's " +
                       std::to_string(kMaxParamsBytes));

  const VkDevice dev = ctx_->device();
  auto k = std::make_unique<Kernel>();
  k->name = name;
  k->index = static_cast<std::uint32_t>(kernels_.size());
  k->bindings = r.bindings;
  k->written = r.written;
  k->push = r.push;
  k->params_buffer = r.params_buffer;
  k->params_bytes = params_bytes;
  std::copy(std::begin(r.local), std::end(r.local), k->local);

  auto module_info = make_info<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  module_info.codeSize = module->word_count * 4;
  module_info.pCode = module->words;
  VkShaderModule shader = VK_NULL_HANDLE;
  check(vkCreateShaderModule(dev, &module_info, nullptr, &shader), "vkCreateShaderModule", name);
  k->module = Unique<VkShaderModule>(dev, shader, vkDestroyShaderModule);

  VkDescriptorSetLayout layouts[2] = {set_layout(r.bindings), params_layout_.get()};
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, (params_bytes + 3) / 4 * 4};
  auto layout_info = make_info<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layout_info.setLayoutCount = r.params_buffer ? 2 : 1;
  layout_info.pSetLayouts = layouts;
  layout_info.pushConstantRangeCount = r.push && params_bytes > 0 ? 1 : 0;
  layout_info.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  check(vkCreatePipelineLayout(dev, &layout_info, nullptr, &layout), "vkCreatePipelineLayout", name);
  k->layout = Unique<VkPipelineLayout>(dev, layout, vkDestroyPipelineLayout);

  auto info = make_info<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = shader;
  info.stage.pName = "main";
  info.layout = layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  check(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
        "vkCreateComputePipelines", name);
  k->pipeline = Unique<VkPipeline>(dev, pipeline, vkDestroyPipeline);
  ++stats_.pipelines_created;
  ctx_->throw_validation_errors((std::string("creating the pipeline of ") + name).c_str());
  return *kernels_.emplace(name, std::move(k)).first->second;
}

VkDescriptorSetLayout Runtime::set_layout(std::uint32_t bindings) {
  if (auto it = set_layouts_.find(bindings); it != set_layouts_.end()) return it->second.get();
  std::vector<VkDescriptorSetLayoutBinding> list(bindings);
  for (std::uint32_t i = 0; i < bindings; ++i) {
    list[i].binding = i;
    list[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    list[i].descriptorCount = 1;
    list[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  auto info = make_info<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  info.bindingCount = bindings;
  info.pBindings = list.data();
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  check(vkCreateDescriptorSetLayout(ctx_->device(), &info, nullptr, &layout), "vkCreateDescriptorSetLayout",
        std::to_string(bindings) + " buffers");
  set_layouts_.emplace(bindings,
                       Unique<VkDescriptorSetLayout>(ctx_->device(), layout, vkDestroyDescriptorSetLayout));
  return layout;
}

VkDescriptorSet Runtime::allocate_set(VkDescriptorSetLayout layout, VkDescriptorPool& from) {
  const VkDevice dev = ctx_->device();
  auto info = make_info<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  info.descriptorSetCount = 1;
  info.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  if (!pools_.empty()) {
    info.descriptorPool = pools_.back().get();
    const VkResult result = vkAllocateDescriptorSets(dev, &info, &set);
    if (result == VK_SUCCESS) {
      from = info.descriptorPool;
      return set;
    }
    if (result != VK_ERROR_OUT_OF_POOL_MEMORY && result != VK_ERROR_FRAGMENTED_POOL)
      check(result, "vkAllocateDescriptorSets");
  }
  // The last pool is full: start another (sets are freed individually when their buffers go).
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kBuffersPerPool};
  auto pool_info = make_info<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pool_info.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pool_info.maxSets = kSetsPerPool;
  pool_info.poolSizeCount = 1;
  pool_info.pPoolSizes = &size;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  check(vkCreateDescriptorPool(dev, &pool_info, nullptr, &pool), "vkCreateDescriptorPool");
  pools_.emplace_back(dev, pool, vkDestroyDescriptorPool);
  info.descriptorPool = pool;
  check(vkAllocateDescriptorSets(dev, &info, &set), "vkAllocateDescriptorSets");
  from = pool;
  return set;
}

VkDescriptorSet Runtime::descriptor_set(const Kernel& k, const std::vector<const VulkanBuffer*>& buffers) {
  std::vector<std::uint64_t> key;
  key.reserve(buffers.size() + 1);
  key.push_back(buffers.size());
  for (const VulkanBuffer* b : buffers) key.push_back(b->memory().id);
  if (auto it = sets_.find(key); it != sets_.end()) return it->second.set;

  const VkDeviceSize max_range = ctx_->limits().maxStorageBufferRange;
  for (const VulkanBuffer* b : buffers)
    if (b->memory().size > max_range)
      throw BackendError("vulkan: " + k.name + ": a buffer of " + std::to_string(b->memory().size) +
                         " bytes is larger than the device's maxStorageBufferRange (" +
                         std::to_string(max_range) + " bytes)");
  SetEntry entry{};
  entry.set = allocate_set(set_layout(k.bindings), entry.pool);
  ++stats_.descriptor_sets_allocated;
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i] = {buffers[i]->memory().buffer.get(), 0, VK_WHOLE_SIZE};
    writes[i] = make_info<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = entry.set;
    writes[i].dstBinding = static_cast<std::uint32_t>(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(ctx_->device(), static_cast<std::uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);
  sets_.emplace(std::move(key), entry);
  return entry.set;
}

bool Runtime::make_dispatch(const char* name, std::initializer_list<const Buffer*> buffers,
                            std::uint32_t params_bytes, Work work, Command& c) {
  Kernel& k = kernel(name, params_bytes);
  const std::string where = std::string("vulkan: ") + name + ": ";
  if (buffers.size() != k.bindings)
    throw BackendError(where + "the shader binds " + std::to_string(k.bindings) +
                       " buffers but the host passes " + std::to_string(buffers.size()));

  // Workgroup counts; counts past the x limit continue in y (porta_linear_index() undoes it).
  const std::uint32_t* limit = ctx_->limits().maxComputeWorkGroupCount;
  std::uint64_t gx = 0, gy = 1;
  switch (work.kind) {
    case Work::Kind::kItems:
    case Work::Kind::kGroups: {
      if (work.kind == Work::Kind::kItems && (k.local[1] != 1 || k.local[2] != 1))
        throw BackendError(where + "Work::items needs a local size of (X, 1, 1)");
      const std::uint64_t groups = work.kind == Work::Kind::kItems ? ceil_div(work.x, k.local[0]) : work.x;
      if (groups == 0) return false;
      gx = std::min<std::uint64_t>(groups, limit[0]);
      gy = ceil_div(groups, gx);
      break;
    }
    case Work::Kind::kGrid:
      if (work.x == 0 || work.y == 0) return false;
      gx = ceil_div(work.x, k.local[0]);
      gy = ceil_div(work.y, k.local[1]);
      break;
  }
  if (gx > limit[0] || gy > limit[1])
    throw BackendError(where + std::to_string(gx) + " x " + std::to_string(gy) +
                       " workgroups exceed the device's limit of " + std::to_string(limit[0]) + " x " +
                       std::to_string(limit[1]));

  std::vector<const VulkanBuffer*> bound;
  bound.reserve(buffers.size());
  for (const Buffer* b : buffers) {
    if (b == nullptr) throw BackendError(where + "a buffer argument is null");
    bound.push_back(&vk(*b, name));
  }

  c.kind = Command::Kind::kDispatch;
  c.kernel = &k;
  c.set = descriptor_set(k, bound);
  for (std::size_t i = 0; i < bound.size(); ++i) {
    c.ids.push_back(bound[i]->memory().id);
    if ((k.written >> i) & 1u) c.writes.push_back(bound[i]->memory().id);
  }
  c.groups[0] = static_cast<std::uint32_t>(gx);
  c.groups[1] = static_cast<std::uint32_t>(gy);
  return true;
}

}  // namespace porta::vulkan
