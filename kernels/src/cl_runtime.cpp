#include "cl_runtime.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "gvd/common/error.h"

namespace gvd::kernels::cl {

std::string error_name(cl_int code) {
  switch (code) {
#define GVD_CL_ERR(x) \
  case x:             \
    return #x;
    GVD_CL_ERR(CL_SUCCESS)
    GVD_CL_ERR(CL_DEVICE_NOT_FOUND)
    GVD_CL_ERR(CL_DEVICE_NOT_AVAILABLE)
    GVD_CL_ERR(CL_COMPILER_NOT_AVAILABLE)
    GVD_CL_ERR(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    GVD_CL_ERR(CL_OUT_OF_RESOURCES)
    GVD_CL_ERR(CL_OUT_OF_HOST_MEMORY)
    GVD_CL_ERR(CL_PROFILING_INFO_NOT_AVAILABLE)
    GVD_CL_ERR(CL_MEM_COPY_OVERLAP)
    GVD_CL_ERR(CL_IMAGE_FORMAT_MISMATCH)
    GVD_CL_ERR(CL_IMAGE_FORMAT_NOT_SUPPORTED)
    GVD_CL_ERR(CL_BUILD_PROGRAM_FAILURE)
    GVD_CL_ERR(CL_MAP_FAILURE)
    GVD_CL_ERR(CL_MISALIGNED_SUB_BUFFER_OFFSET)
    GVD_CL_ERR(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
    GVD_CL_ERR(CL_COMPILE_PROGRAM_FAILURE)
    GVD_CL_ERR(CL_LINKER_NOT_AVAILABLE)
    GVD_CL_ERR(CL_LINK_PROGRAM_FAILURE)
    GVD_CL_ERR(CL_DEVICE_PARTITION_FAILED)
    GVD_CL_ERR(CL_KERNEL_ARG_INFO_NOT_AVAILABLE)
    GVD_CL_ERR(CL_INVALID_VALUE)
    GVD_CL_ERR(CL_INVALID_DEVICE_TYPE)
    GVD_CL_ERR(CL_INVALID_PLATFORM)
    GVD_CL_ERR(CL_INVALID_DEVICE)
    GVD_CL_ERR(CL_INVALID_CONTEXT)
    GVD_CL_ERR(CL_INVALID_QUEUE_PROPERTIES)
    GVD_CL_ERR(CL_INVALID_COMMAND_QUEUE)
    GVD_CL_ERR(CL_INVALID_HOST_PTR)
    GVD_CL_ERR(CL_INVALID_MEM_OBJECT)
    GVD_CL_ERR(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR)
    GVD_CL_ERR(CL_INVALID_IMAGE_SIZE)
    GVD_CL_ERR(CL_INVALID_SAMPLER)
    GVD_CL_ERR(CL_INVALID_BINARY)
    GVD_CL_ERR(CL_INVALID_BUILD_OPTIONS)
    GVD_CL_ERR(CL_INVALID_PROGRAM)
    GVD_CL_ERR(CL_INVALID_PROGRAM_EXECUTABLE)
    GVD_CL_ERR(CL_INVALID_KERNEL_NAME)
    GVD_CL_ERR(CL_INVALID_KERNEL_DEFINITION)
    GVD_CL_ERR(CL_INVALID_KERNEL)
    GVD_CL_ERR(CL_INVALID_ARG_INDEX)
    GVD_CL_ERR(CL_INVALID_ARG_VALUE)
    GVD_CL_ERR(CL_INVALID_ARG_SIZE)
    GVD_CL_ERR(CL_INVALID_KERNEL_ARGS)
    GVD_CL_ERR(CL_INVALID_WORK_DIMENSION)
    GVD_CL_ERR(CL_INVALID_WORK_GROUP_SIZE)
    GVD_CL_ERR(CL_INVALID_WORK_ITEM_SIZE)
    GVD_CL_ERR(CL_INVALID_GLOBAL_OFFSET)
    GVD_CL_ERR(CL_INVALID_EVENT_WAIT_LIST)
    GVD_CL_ERR(CL_INVALID_EVENT)
    GVD_CL_ERR(CL_INVALID_OPERATION)
    GVD_CL_ERR(CL_INVALID_GL_OBJECT)
    GVD_CL_ERR(CL_INVALID_BUFFER_SIZE)
    GVD_CL_ERR(CL_INVALID_MIP_LEVEL)
    GVD_CL_ERR(CL_INVALID_GLOBAL_WORK_SIZE)
    GVD_CL_ERR(CL_INVALID_PROPERTY)
    GVD_CL_ERR(CL_INVALID_IMAGE_DESCRIPTOR)
    GVD_CL_ERR(CL_INVALID_COMPILER_OPTIONS)
    GVD_CL_ERR(CL_INVALID_LINKER_OPTIONS)
    GVD_CL_ERR(CL_INVALID_DEVICE_PARTITION_COUNT)
#undef GVD_CL_ERR
    case -1001:
      return "CL_PLATFORM_NOT_FOUND_KHR";
    default:
      return "CL error " + std::to_string(code);
  }
}

void check(cl_int code, const char* call, const std::string& detail) {
  if (code == CL_SUCCESS) return;
  throw Error(ErrorCode::kInternal, std::string("OpenCL: ") + call +
                                        " failed: " + error_name(code) + " (" +
                                        std::to_string(code) + ")" + detail);
}

namespace {

std::string platform_string(cl_platform_id p, cl_platform_info what) {
  size_t n = 0;
  check(clGetPlatformInfo(p, what, 0, nullptr, &n), "clGetPlatformInfo");
  std::string s(n, '\0');
  check(clGetPlatformInfo(p, what, n, s.data(), nullptr), "clGetPlatformInfo");
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string device_string(cl_device_id d, cl_device_info what) {
  size_t n = 0;
  check(clGetDeviceInfo(d, what, 0, nullptr, &n), "clGetDeviceInfo");
  std::string s(n, '\0');
  check(clGetDeviceInfo(d, what, n, s.data(), nullptr), "clGetDeviceInfo");
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

std::vector<DeviceInfo> list_devices(std::string* why) {
  std::vector<DeviceInfo> out;
  cl_uint np = 0;
  const cl_int err = clGetPlatformIDs(0, nullptr, &np);
  if (err != CL_SUCCESS || np == 0) {
    if (why) {
      *why = "no OpenCL platform (clGetPlatformIDs: " +
             (err == CL_SUCCESS ? std::string("0 platforms") : error_name(err)) + ")";
    }
    return out;
  }
  std::vector<cl_platform_id> platforms(np);
  check(clGetPlatformIDs(np, platforms.data(), nullptr), "clGetPlatformIDs");
  std::string errors;
  for (cl_platform_id p : platforms) {
    cl_uint nd = 0;
    const cl_int e = clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd);
    if (e != CL_SUCCESS || nd == 0) {
      errors += " " + platform_string(p, CL_PLATFORM_NAME) + ": " +
                (e == CL_SUCCESS ? std::string("0 devices") : error_name(e)) + ";";
      continue;
    }
    std::vector<cl_device_id> devices(nd);
    check(clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, devices.data(), nullptr), "clGetDeviceIDs");
    for (cl_device_id d : devices) {
      DeviceInfo info;
      info.platform = p;
      info.device = d;
      info.platform_name = platform_string(p, CL_PLATFORM_NAME);
      info.device_name = device_string(d, CL_DEVICE_NAME);
      info.device_version = device_string(d, CL_DEVICE_VERSION);
      info.driver_version = device_string(d, CL_DRIVER_VERSION);
      check(clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof info.type, &info.type, nullptr),
            "clGetDeviceInfo");
      cl_device_fp_config fp = 0;
      check(clGetDeviceInfo(d, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp, &fp, nullptr),
            "clGetDeviceInfo");
      info.fp64 = fp != 0;
      out.push_back(std::move(info));
    }
  }
  if (out.empty() && why) {
    *why = "no OpenCL device (CL_DEVICE_NOT_FOUND on every platform:" + errors +
           " is POCL_CACHE_DIR writable?)";
  }
  return out;
}

DeviceInfo choose_device(const std::vector<DeviceInfo>& devices, const std::string& selector) {
  std::string names;
  for (const DeviceInfo& d : devices) names += " [" + d.label() + "]";
  if (selector.empty()) {
    for (const DeviceInfo& d : devices)
      if (d.fp64 && (d.type & CL_DEVICE_TYPE_GPU)) return d;
    for (const DeviceInfo& d : devices)
      if (d.fp64) return d;
    throw Error(ErrorCode::kInvalidArgument,
                "no OpenCL device supports double precision (cl_khr_fp64):" + names);
  }
  const size_t colon = selector.find(':');
  if (colon != std::string::npos && std::all_of(selector.begin(), selector.end(), [](char c) {
        return c == ':' || std::isdigit(static_cast<unsigned char>(c));
      })) {
    const int pi = std::atoi(selector.substr(0, colon).c_str());
    const int di = std::atoi(selector.substr(colon + 1).c_str());
    int p = -1, dd = 0;
    cl_platform_id last = nullptr;
    for (const DeviceInfo& d : devices) {
      if (d.platform != last) {
        ++p;
        dd = 0;
        last = d.platform;
      }
      if (p == pi && dd == di) return d;
      ++dd;
    }
  } else {
    const std::string want = lower(selector);
    for (const DeviceInfo& d : devices)
      if (lower(d.label()).find(want) != std::string::npos) return d;
  }
  throw Error(ErrorCode::kInvalidArgument,
              "GVD_OPENCL_DEVICE='" + selector + "' matches no OpenCL device; devices:" + names);
}

Runtime make_runtime(const DeviceInfo& device) {
  Runtime rt;
  rt.device = device;
  cl_int err = CL_SUCCESS;
  const cl_context_properties props[] = {
      CL_CONTEXT_PLATFORM, reinterpret_cast<cl_context_properties>(device.platform), 0};
  rt.context = Context(clCreateContext(props, 1, &device.device, nullptr, nullptr, &err));
  check(err, "clCreateContext", " on " + device.label());
  rt.queue = Queue(clCreateCommandQueue(rt.context.get(), device.device, 0, &err));
  check(err, "clCreateCommandQueue", " on " + device.label());
  return rt;
}

std::string resolve_cache_dir(const std::string& requested) {
  if (!requested.empty()) return requested;
  if (const char* e = std::getenv("GVD_KERNEL_CACHE_DIR"); e && *e) return e;
  if (const char* e = std::getenv("XDG_CACHE_HOME"); e && *e)
    return std::string(e) + "/gvd/kernels";
  if (const char* e = std::getenv("HOME"); e && *e) return std::string(e) + "/.cache/gvd/kernels";
  return "";
}

uint64_t fnv1a64(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

namespace {

constexpr char kCacheMagic[] = "GVDCLBIN1\n";

std::string build_log(const Program& program, cl_device_id device) {
  size_t n = 0;
  if (clGetProgramBuildInfo(program.get(), device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n) !=
      CL_SUCCESS)
    return "(no build log)";
  std::string log(n, '\0');
  clGetProgramBuildInfo(program.get(), device, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
  while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
  return log;
}

// Builds (compiles from source, or finalises a loaded binary); throws with the build log.
void build(const Program& program, const Runtime& rt, const std::string& options) {
  const cl_int err =
      clBuildProgram(program.get(), 1, &rt.device.device, options.c_str(), nullptr, nullptr);
  if (err != CL_SUCCESS) {
    check(err, "clBuildProgram",
          " on " + rt.device.label() + " with options '" + options + "'; build log:\n" +
              build_log(program, rt.device.device));
  }
}

// The cached file holds the whole key text (so a hash collision can never load a wrong
// binary), then the binary.
std::string read_cached(const std::string& path, const std::string& key) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return {};
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string all = ss.str();
  const std::string head = std::string(kCacheMagic) + std::to_string(key.size()) + "\n" + key;
  if (all.size() <= head.size() || all.compare(0, head.size(), head) != 0) return {};
  return all.substr(head.size());
}

void write_cached(const std::string& dir, const std::string& path, const std::string& key,
                  const std::vector<unsigned char>& binary) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) return;  // unwritable: run without the cache
    f << kCacheMagic << key.size() << "\n" << key;
    f.write(reinterpret_cast<const char*>(binary.data()),
            static_cast<std::streamsize>(binary.size()));
    if (!f) {
      std::filesystem::remove(tmp, ec);
      return;
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) std::filesystem::remove(tmp, ec);
}

}  // namespace

Program build_program(const Runtime& rt, const std::string& source, const std::string& options,
                      const std::string& cache_dir, BuildInfo* info) {
  const auto start = std::chrono::steady_clock::now();
  BuildInfo local;
  const std::string key = "options=" + options + "\nplatform=" + rt.device.platform_name +
                          "\ndevice=" + rt.device.device_name +
                          "\nversion=" + rt.device.device_version +
                          "\ndriver=" + rt.device.driver_version + "\nsource=" + source;
  cl_int err = CL_SUCCESS;
  Program program;
  if (!cache_dir.empty()) {
    char name[40];
    std::snprintf(name, sizeof name, "%016llx.bin", static_cast<unsigned long long>(fnv1a64(key)));
    local.cache_file = cache_dir + "/" + name;
    const std::string binary = read_cached(local.cache_file, key);
    if (!binary.empty()) {
      const size_t size = binary.size();
      const auto* bytes = reinterpret_cast<const unsigned char*>(binary.data());
      cl_int status = CL_SUCCESS;
      Program cached(clCreateProgramWithBinary(rt.context.get(), 1, &rt.device.device, &size,
                                               &bytes, &status, &err));
      if (err == CL_SUCCESS && status == CL_SUCCESS &&
          clBuildProgram(cached.get(), 1, &rt.device.device, options.c_str(), nullptr, nullptr) ==
              CL_SUCCESS) {
        program = std::move(cached);
        local.from_cache = true;
      }
    }
  }
  if (!program) {
    const char* text = source.c_str();
    const size_t length = source.size();
    program = Program(clCreateProgramWithSource(rt.context.get(), 1, &text, &length, &err));
    check(err, "clCreateProgramWithSource");
    build(program, rt, options);
    if (!local.cache_file.empty()) {
      size_t size = 0;
      check(clGetProgramInfo(program.get(), CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr),
            "clGetProgramInfo", " (CL_PROGRAM_BINARY_SIZES)");
      if (size > 0) {
        std::vector<unsigned char> binary(size);
        unsigned char* ptr = binary.data();
        check(clGetProgramInfo(program.get(), CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr),
              "clGetProgramInfo", " (CL_PROGRAM_BINARIES)");
        write_cached(cache_dir, local.cache_file, key, binary);
      }
    }
  }
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (info) *info = local;
  return program;
}

Kernel make_kernel(const Program& program, const char* name) {
  cl_int err = CL_SUCCESS;
  Kernel k(clCreateKernel(program.get(), name, &err));
  check(err, "clCreateKernel", std::string(" (") + name + ")");
  return k;
}

Buffer make_buffer(const Runtime& rt, cl_mem_flags flags, size_t bytes, const void* host) {
  cl_int err = CL_SUCCESS;
  if (host != nullptr) flags |= CL_MEM_COPY_HOST_PTR;
  Buffer b(clCreateBuffer(rt.context.get(), flags, bytes, const_cast<void*>(host), &err));
  check(err, "clCreateBuffer", " (" + std::to_string(bytes) + " bytes)");
  return b;
}

}  // namespace gvd::kernels::cl
