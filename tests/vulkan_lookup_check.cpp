// The runtime's Vulkan lookup shader (libcpvs/runtime/cpvs_visibility.comp) run on a Vulkan device (Mesa's lavapipe
// where there is no GPU): its answers against the CPU runtime's LightShadow::visibility, point by point, on a
// TorusKnot bake under a sun, a spot and a point light (six cube faces) in format 2.0 and its 3.0 twin, K = 1, 3
// and 9. The shader is compiled by glslangValidator at run time. Skipped without glslangValidator or a Vulkan
// device with shaderFloat64. Built only where CMake finds Vulkan (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/base/error.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_shadows.h"
#include "libcpvs/scene/surface_samples.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

#define VK_OK(call)                                                                   \
  do {                                                                                \
    const VkResult r = (call);                                                        \
    if (r != VK_SUCCESS) throw std::runtime_error(#call " failed: " + std::to_string(int(r))); \
  } while (0)

// A Vulkan structure of the given type, every other member zero.
template <class T>
T make(VkStructureType type) {
  T value{};
  value.sType = type;
  return value;
}

// The push constants of cpvs_visibility.comp (std430: 24 bytes).
struct PushConstants {
  double biasMargin;
  uint32_t light, count;
  int32_t pcfKernel, pad;
};

// One Vulkan device and the lookup pipeline, for the process.
class VulkanLookup {
public:
  std::string unavailable;  // why the test is skipped

  VulkanLookup() {
    const std::string spv = test::tempDir() + "/cpvs_visibility.spv";
    const std::string runtime = std::string(CPVS_SOURCE_DIR) + "/libcpvs/runtime";
    const std::string compile = "glslangValidator -V --target-env vulkan1.1 -I" + runtime + " -o " + spv + " " +
                                runtime + "/cpvs_visibility.comp > " + spv + ".log 2>&1";
    if (std::system("command -v glslangValidator > /dev/null") != 0) {
      unavailable = "no glslangValidator (glslang-tools)";
      return;
    }
    if (std::system(compile.c_str()) != 0) throw std::runtime_error("cpvs_visibility.comp does not compile: see " + spv + ".log");
    std::ifstream in(spv, std::ios::binary);
    code_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());

    auto app = make<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.apiVersion = VK_API_VERSION_1_1;
    auto instanceInfo = make<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    instanceInfo.pApplicationInfo = &app;
    if (vkCreateInstance(&instanceInfo, nullptr, &instance_) != VK_SUCCESS) {
      unavailable = "no Vulkan instance";
      return;
    }
    uint32_t count = 0;
    vkEnumeratePhysicalDevices(instance_, &count, nullptr);
    std::vector<VkPhysicalDevice> devices(count);
    vkEnumeratePhysicalDevices(instance_, &count, devices.data());
    for (VkPhysicalDevice d : devices) {
      VkPhysicalDeviceFeatures features;
      vkGetPhysicalDeviceFeatures(d, &features);
      uint32_t families = 0;
      vkGetPhysicalDeviceQueueFamilyProperties(d, &families, nullptr);
      std::vector<VkQueueFamilyProperties> props(families);
      vkGetPhysicalDeviceQueueFamilyProperties(d, &families, props.data());
      for (uint32_t f = 0; f < families && !physical_; ++f)
        if ((props[f].queueFlags & VK_QUEUE_COMPUTE_BIT) && features.shaderFloat64) physical_ = d, family_ = f;
    }
    if (!physical_) {
      unavailable = "no Vulkan device with compute and shaderFloat64";
      return;
    }
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(physical_, &properties);
    std::printf("[ vulkan   ] %s\n", properties.deviceName);
    const float priority = 1.0f;
    auto queueInfo = make<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    queueInfo.queueFamilyIndex = family_;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;
    VkPhysicalDeviceFeatures enabled{};
    enabled.shaderFloat64 = VK_TRUE;
    auto deviceInfo = make<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    deviceInfo.queueCreateInfoCount = 1;
    deviceInfo.pQueueCreateInfos = &queueInfo;
    deviceInfo.pEnabledFeatures = &enabled;
    VK_OK(vkCreateDevice(physical_, &deviceInfo, nullptr, &device_));
    vkGetDeviceQueue(device_, family_, 0, &queue_);
    makePipeline();
  }

  ~VulkanLookup() {
    if (device_) {
      vkDestroyPipeline(device_, pipeline_, nullptr);
      vkDestroyPipelineLayout(device_, layout_, nullptr);
      vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
      vkDestroyDevice(device_, nullptr);
    }
    if (instance_) vkDestroyInstance(instance_, nullptr);
  }
  VulkanLookup(const VulkanLookup&) = delete;
  VulkanLookup& operator=(const VulkanLookup&) = delete;

  // The shader's answer for every point, light `light`, kernel K.
  std::vector<float> run(const GpuSceneRecords& r, const std::vector<SurfacePoint>& points, uint32_t light, int k) {
    const std::vector<std::pair<const void*, size_t>> data = {
        {r.lightReals.data(), r.lightReals.size() * 8}, {r.lightWords.data(), r.lightWords.size() * 4},
        {r.viewReals.data(), r.viewReals.size() * 8},   {r.viewWords.data(), r.viewWords.size() * 4},
        {r.nodes.data(), r.nodes.size() * 4},           {r.leaves.data(), r.leaves.size() * 8},
        {points.data(), points.size() * sizeof(SurfacePoint)}, {nullptr, points.size() * 4}};
    std::vector<VkBuffer> buffers;
    std::vector<VkDeviceMemory> memories;
    for (const auto& [bytes, size] : data) {
      auto info = make<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
      info.size = std::max<size_t>(size, 16);
      info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
      VkBuffer buffer;
      VK_OK(vkCreateBuffer(device_, &info, nullptr, &buffer));
      VkMemoryRequirements needs;
      vkGetBufferMemoryRequirements(device_, buffer, &needs);
      auto alloc = make<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
      alloc.allocationSize = needs.size;
      alloc.memoryTypeIndex = hostVisibleType(needs.memoryTypeBits);
      VkDeviceMemory memory;
      VK_OK(vkAllocateMemory(device_, &alloc, nullptr, &memory));
      VK_OK(vkBindBufferMemory(device_, buffer, memory, 0));
      void* mapped = nullptr;
      VK_OK(vkMapMemory(device_, memory, 0, VK_WHOLE_SIZE, 0, &mapped));
      std::memset(mapped, 0, info.size);
      if (bytes && size) std::memcpy(mapped, bytes, size);
      vkUnmapMemory(device_, memory);
      buffers.push_back(buffer);
      memories.push_back(memory);
    }
    VkDescriptorPoolSize poolSize{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 8};
    auto poolInfo = make<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    poolInfo.maxSets = 1;
    poolInfo.poolSizeCount = 1;
    poolInfo.pPoolSizes = &poolSize;
    VkDescriptorPool pool;
    VK_OK(vkCreateDescriptorPool(device_, &poolInfo, nullptr, &pool));
    auto setInfo = make<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    setInfo.descriptorPool = pool;
    setInfo.descriptorSetCount = 1;
    setInfo.pSetLayouts = &setLayout_;
    VkDescriptorSet set;
    VK_OK(vkAllocateDescriptorSets(device_, &setInfo, &set));
    std::vector<VkDescriptorBufferInfo> infos(8);
    std::vector<VkWriteDescriptorSet> writes(8);
    for (uint32_t b = 0; b < 8; ++b) {
      infos[b] = {buffers[b], 0, VK_WHOLE_SIZE};
      writes[b] = make<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
      writes[b].dstSet = set;
      writes[b].dstBinding = b;
      writes[b].descriptorCount = 1;
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[b].pBufferInfo = &infos[b];
    }
    vkUpdateDescriptorSets(device_, 8, writes.data(), 0, nullptr);
    auto commandPoolInfo = make<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    commandPoolInfo.queueFamilyIndex = family_;
    VkCommandPool commandPool;
    VK_OK(vkCreateCommandPool(device_, &commandPoolInfo, nullptr, &commandPool));
    auto commandInfo = make<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    commandInfo.commandPool = commandPool;
    commandInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    commandInfo.commandBufferCount = 1;
    VkCommandBuffer commands;
    VK_OK(vkAllocateCommandBuffers(device_, &commandInfo, &commands));
    auto begin = make<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    VK_OK(vkBeginCommandBuffer(commands, &begin));
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set, 0, nullptr);
    const PushConstants push{kDefaultBiasMargin, light, uint32_t(points.size()), k, 0};
    vkCmdPushConstants(commands, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, 24, &push);
    vkCmdDispatch(commands, uint32_t((points.size() + 63) / 64), 1, 1);
    VK_OK(vkEndCommandBuffer(commands));
    auto submit = make<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &commands;
    VK_OK(vkQueueSubmit(queue_, 1, &submit, VK_NULL_HANDLE));
    VK_OK(vkQueueWaitIdle(queue_));
    std::vector<float> answers(points.size());
    void* mapped = nullptr;
    VK_OK(vkMapMemory(device_, memories[7], 0, VK_WHOLE_SIZE, 0, &mapped));
    std::memcpy(answers.data(), mapped, answers.size() * 4);
    vkUnmapMemory(device_, memories[7]);
    vkDestroyCommandPool(device_, commandPool, nullptr);
    vkDestroyDescriptorPool(device_, pool, nullptr);
    for (size_t b = 0; b < buffers.size(); ++b) {
      vkDestroyBuffer(device_, buffers[b], nullptr);
      vkFreeMemory(device_, memories[b], nullptr);
    }
    return answers;
  }

private:
  uint32_t hostVisibleType(uint32_t allowed) const {
    VkPhysicalDeviceMemoryProperties memory;
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory);
    const VkMemoryPropertyFlags wanted = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    for (uint32_t t = 0; t < memory.memoryTypeCount; ++t)
      if ((allowed & (1u << t)) && (memory.memoryTypes[t].propertyFlags & wanted) == wanted) return t;
    throw std::runtime_error("no host-visible, coherent memory type");
  }

  void makePipeline() {
    std::vector<VkDescriptorSetLayoutBinding> bindings(8);
    for (uint32_t b = 0; b < 8; ++b)
      bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    auto setInfo = make<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    setInfo.bindingCount = 8;
    setInfo.pBindings = bindings.data();
    VK_OK(vkCreateDescriptorSetLayout(device_, &setInfo, nullptr, &setLayout_));
    const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 24};
    auto layoutInfo = make<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &setLayout_;
    layoutInfo.pushConstantRangeCount = 1;
    layoutInfo.pPushConstantRanges = &range;
    VK_OK(vkCreatePipelineLayout(device_, &layoutInfo, nullptr, &layout_));
    auto moduleInfo = make<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    moduleInfo.codeSize = code_.size();
    moduleInfo.pCode = reinterpret_cast<const uint32_t*>(code_.data());
    VkShaderModule module;
    VK_OK(vkCreateShaderModule(device_, &moduleInfo, nullptr, &module));
    auto pipelineInfo = make<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    pipelineInfo.stage = make<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    pipelineInfo.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    pipelineInfo.stage.module = module;
    pipelineInfo.stage.pName = "main";
    pipelineInfo.layout = layout_;
    VK_OK(vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &pipelineInfo, nullptr, &pipeline_));
    vkDestroyShaderModule(device_, module, nullptr);
  }

  std::string code_;
  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  uint32_t family_ = 0;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

TEST(VulkanLookup, AnswersAsTheCpuRuntime) {
  const auto vulkan = std::make_unique<VulkanLookup>();
  if (!vulkan->unavailable.empty()) GTEST_SKIP() << vulkan->unavailable;
  Scene scene = importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
  scene.lights = {test::sunLight("sun", {0.3, -1.0, 0.2}), test::spotLight("spot", {5, 60, 0}, {0, -1, 0}, 0.6, 150),
                  test::pointLight("point", {20, 25, 15}, 120)};
  BakeSettings settings;
  settings.resolution = 256;
  settings.threads = 2;
  const CpvsContent content = bakeScene(scene, settings);
  std::vector<SurfacePoint> points;
  for (const SurfaceSample& s : sampleSurfaces(flatten(scene), 3000, 5)) points.push_back({s.position, s.normal});
  size_t compared = 0, lit = 0;
  for (const uint16_t major : {uint16_t(2), uint16_t(3)}) {
    const std::string bytes = writeCpvs(content, major);
    const auto file = orThrow(CpvsFile::fromBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, "tk"));
    std::vector<LightShadow> lights;
    for (const CpvsFile::LightEntry& e : file->lights()) lights.push_back(orThrow(lightShadowOf(e)));
    const GpuSceneRecords records = orThrow(packGpuScene(lights));
    for (uint32_t l = 0; l < lights.size(); ++l)
      for (int k : {1, 3, 9}) {
        std::vector<float> cpu(points.size());
        orThrow(lights[l].visibility(points, {k}, cpu));
        const std::vector<float> gpu = vulkan->run(records, points, l, k);
        for (size_t i = 0; i < points.size(); ++i) {
          ASSERT_EQ(gpu[i], cpu[i]) << "format " << major << " light " << l << " K=" << k << " point " << i;
          lit += cpu[i] == 1.0f;
        }
        compared += points.size();
      }
  }
  std::printf("[ compared ] %zu answers, %zu lit\n", compared, lit);
  EXPECT_GT(lit, compared / 10);
  EXPECT_LT(lit, compared * 9 / 10);
}

}  // namespace
}  // namespace cpvs
