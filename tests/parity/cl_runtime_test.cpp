// The OpenCL host layer: build errors carry the compiler's log, the binary cache is keyed and
// self-checking, device selection by index and by name, error names.

#include "cl_runtime.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "gvd/common/error.h"
#include "parity/opencl_env.h"

namespace gvd::kernels {
namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char tmpl[] = "/tmp/gvd-cl-test-XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

cl::Runtime runtime() {
  std::string why;
  const auto devices = cl::list_devices(&why);
  return cl::make_runtime(cl::choose_device(devices, ""));
}

TEST(ClRuntime, BuildErrorsCarryTheBuildLog) {
  GVD_REQUIRE_OPENCL(backend);
  const cl::Runtime rt = runtime();
  try {
    cl::build_program(rt, "__kernel void broken(__global int* x) { x[0] = undefined_name; }",
                      "-cl-std=CL1.2", "");
    ADD_FAILURE() << "a broken kernel must not build";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("clBuildProgram"), std::string::npos) << what;
    EXPECT_NE(what.find("CL_BUILD_PROGRAM_FAILURE"), std::string::npos) << what;
    EXPECT_NE(what.find("undefined_name"), std::string::npos) << "no build log in: " << what;
  }
}

TEST(ClRuntime, BinaryCacheHitsAndSurvivesACorruptFile) {
  GVD_REQUIRE_OPENCL(backend);
  const cl::Runtime rt = runtime();
  const TempDir dir;
  const std::string src = "__kernel void twice(__global int* x) { x[get_global_id(0)] *= 2; }";
  cl::BuildInfo a, b, c, d;
  cl::build_program(rt, src, "-cl-std=CL1.2", dir.path, &a);
  EXPECT_FALSE(a.from_cache);
  ASSERT_TRUE(std::filesystem::exists(a.cache_file));
  cl::build_program(rt, src, "-cl-std=CL1.2", dir.path, &b);
  EXPECT_TRUE(b.from_cache);
  EXPECT_EQ(a.cache_file, b.cache_file);
  // Other options or source: another key.
  cl::build_program(rt, src, "-cl-std=CL1.2 -DX=1", dir.path, &c);
  EXPECT_FALSE(c.from_cache);
  EXPECT_NE(c.cache_file, a.cache_file);
  // A damaged file is ignored and rewritten.
  std::ofstream(a.cache_file, std::ios::binary | std::ios::trunc) << "garbage";
  cl::build_program(rt, src, "-cl-std=CL1.2", dir.path, &d);
  EXPECT_FALSE(d.from_cache);
  cl::build_program(rt, src, "-cl-std=CL1.2", dir.path, &d);
  EXPECT_TRUE(d.from_cache);
  // An unwritable cache directory only disables the cache.
  cl::BuildInfo e;
  EXPECT_NO_THROW(cl::build_program(rt, src, "-cl-std=CL1.2", "/proc/gvd-no-such-dir", &e));
  EXPECT_FALSE(e.from_cache);
}

TEST(ClRuntime, DeviceSelectionByIndexAndName) {
  GVD_REQUIRE_OPENCL(backend);
  std::string why;
  const auto devices = cl::list_devices(&why);
  ASSERT_FALSE(devices.empty());
  EXPECT_EQ(cl::choose_device(devices, "0:0").device, devices[0].device);
  const std::string part = devices[0].device_name.substr(0, 4);
  EXPECT_EQ(cl::choose_device(devices, part).device, devices[0].device);
  try {
    cl::choose_device(devices, "no-such-device-anywhere");
    ADD_FAILURE() << "an unknown device must be an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find(devices[0].device_name), std::string::npos)
        << "the error should list the devices: " << e.what();
  }
  EXPECT_THROW(cl::choose_device(devices, "7:7"), Error);
}

TEST(ClRuntime, ErrorNames) {
  EXPECT_EQ(cl::error_name(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES");
  EXPECT_EQ(cl::error_name(-1001), "CL_PLATFORM_NOT_FOUND_KHR");
  EXPECT_EQ(cl::error_name(-12345), "CL error -12345");
  try {
    cl::check(CL_INVALID_KERNEL_ARGS, "clEnqueueNDRangeKernel", " (k)");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_STREQ(
        e.what(),
        "internal: OpenCL: clEnqueueNDRangeKernel failed: CL_INVALID_KERNEL_ARGS (-52) (k)");
  }
}

}  // namespace
}  // namespace gvd::kernels
