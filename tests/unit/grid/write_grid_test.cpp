// The grid files (io/write_grid.h) read back by readers that are not ours: numpy (Debian's
// python3-numpy, through /usr/bin/python3: np.load and numpy.lib.format's own header parser)
// for .npy and for the raw data of detached NRRD, and a field-by-field check of the NRRD
// header here. Values are compared with the grid the files were written from.

#include "gvd/io/write_grid.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "gvd/common/error.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::grid;
using namespace gvd::io;

namespace {

std::string out_path(const std::string& name) {
  return std::string(GVD_TEST_OUTPUT_DIR) + "/grid_" + name;
}

std::string read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

DistanceGrid small_grid(int dimension) {
  GridOptions o;
  o.resolution = dimension == 2 ? 13 : 7;  // odd sizes: no accidental symmetry of axes
  if (dimension == 2) {
    return compute_grid(
        test::make_scene(2, {test::make_rect("sq", {0.2, 0.2, 0}, {0.5, 0.4, 0}),
                             test::make_segment("s", {0.7, 0.1, 0}, {0.9, 0.6, 0})}),
        o);
  }
  return compute_grid(test::make_scene(3, {test::make_box("b", {0.1, 0.1, 0.1}, {0.4, 0.5, 0.3}),
                                           test::make_sphere("s", {0.7, 0.6, 0.7}, 0.2, 4, 8)}),
                      o);
}

// Writes the values as text (exactly round-tripping) for the Python side to compare with.
void write_text(const DistanceGrid& g, const std::string& path, int what) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  for (size_t i = 0; i < g.label.size(); ++i) {
    if (what == 0)
      std::fprintf(f, "%.9g\n", static_cast<double>(static_cast<float>(g.distance[i])));
    if (what == 1) std::fprintf(f, "%.17g\n", g.distance[i]);
    if (what == 2) std::fprintf(f, "%d\n", g.label[i]);
  }
  std::fclose(f);
}

bool have_numpy() {
  return std::system("/usr/bin/python3 -c 'import numpy' > /dev/null 2>&1") == 0;
}

// Runs a Python check; returns its exit code.
int python(const std::string& script) {
  const std::string file = out_path("check.py");
  std::ofstream(file) << script;
  return std::system(("/usr/bin/python3 " + file).c_str());
}

TEST(WriteGrid, NpyHeaderIsPaddedTo64AndHoldsTheShape) {
  const DistanceGrid g = small_grid(3);
  const std::vector<uint64_t> shape = grid_shape(g.spec);
  ASSERT_EQ(shape, (std::vector<uint64_t>{static_cast<uint64_t>(g.spec.n[2]),
                                          static_cast<uint64_t>(g.spec.n[1]),
                                          static_cast<uint64_t>(g.spec.n[0])}));
  const std::vector<uint8_t> b = npy_bytes(GridValueType::kInt32, shape, g.label.data());
  ASSERT_GE(b.size(), 10u);
  EXPECT_EQ(std::memcmp(b.data(), "\x93NUMPY\x01\x00", 8), 0);
  const size_t header = b[8] | (b[9] << 8);
  EXPECT_EQ((10 + header) % 64, 0u);
  const std::string dict(reinterpret_cast<const char*>(b.data()) + 10, header);
  EXPECT_EQ(dict.back(), '\n');
  EXPECT_NE(dict.find("'descr': '<i4'"), std::string::npos) << dict;
  EXPECT_NE(dict.find("'fortran_order': False"), std::string::npos) << dict;
  EXPECT_NE(dict.find("'shape': (" + std::to_string(g.spec.n[2]) + ", " +
                      std::to_string(g.spec.n[1]) + ", " + std::to_string(g.spec.n[0]) + ")"),
            std::string::npos)
      << dict;
  ASSERT_EQ(b.size(), 10 + header + 4 * g.label.size());
  EXPECT_EQ(std::memcmp(b.data() + 10 + header, g.label.data(), 4 * g.label.size()), 0);
}

TEST(WriteGrid, NumpyReadsTheFilesBack) {
  if (!have_numpy())
    GTEST_SKIP() << "/usr/bin/python3 has no numpy (apt-get install python3-numpy)";
  for (int dim : {2, 3}) {
    const DistanceGrid g = small_grid(dim);
    const std::string d = std::to_string(dim);
    write_grid_distance(g, out_path("d32_" + d + ".npy"), false);
    write_grid_distance(g, out_path("d64_" + d + ".npy"), true);
    write_grid_labels(g, out_path("l_" + d + ".npy"));
    write_grid_distance(g, out_path("d32_" + d + ".nhdr"), false);
    write_text(g, out_path("d32_" + d + ".txt"), 0);
    write_text(g, out_path("d64_" + d + ".txt"), 1);
    write_text(g, out_path("l_" + d + ".txt"), 2);
    std::string shape = "(";
    if (dim == 3) shape += std::to_string(g.spec.n[2]) + ",";
    shape += std::to_string(g.spec.n[1]) + "," + std::to_string(g.spec.n[0]) + ")";
    const std::string base = out_path("");
    const std::string script = R"(
import sys, numpy as np
from numpy.lib import format as fmt
base, d, shape = ")" + base + R"(", ")" +
                               d + R"(", )" + shape + R"(
def check(npy, txt, dtype):
    a = np.load(base + npy)
    assert a.dtype == np.dtype(dtype), (npy, a.dtype)
    assert a.shape == shape, (npy, a.shape, shape)
    want = np.loadtxt(base + txt, dtype=dtype).reshape(shape)
    assert np.array_equal(a, want), npy
    with open(base + npy, 'rb') as f:
        assert fmt.read_magic(f) == (1, 0)
        s, fortran, dt = fmt.read_array_header_1_0(f)
        assert s == shape and not fortran and dt == np.dtype(dtype)
        assert f.tell() % 64 == 0, f.tell()
check('d32_' + d + '.npy', 'd32_' + d + '.txt', '<f4')
check('d64_' + d + '.npy', 'd64_' + d + '.txt', '<f8')
check('l_' + d + '.npy', 'l_' + d + '.txt', '<i4')
raw = np.fromfile(base + 'd32_' + d + '.raw', dtype='<f4').reshape(shape)
assert np.array_equal(raw, np.loadtxt(base + 'd32_' + d + '.txt', dtype='<f4').reshape(shape))
)";
    EXPECT_EQ(python(script), 0) << dim << "D";
  }
}

// Parses a NRRD header: field -> value, up to the blank line (attached) or the end.
std::map<std::string, std::string> parse_nrrd(const std::string& text, size_t* data_start) {
  std::map<std::string, std::string> f;
  size_t pos = text.find('\n') + 1;  // after NRRD0004
  EXPECT_EQ(text.substr(0, 9), "NRRD0004\n");
  while (pos < text.size()) {
    const size_t end = text.find('\n', pos);
    const std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    if (line.empty()) break;
    if (line[0] == '#') continue;
    const size_t colon = line.find(": ");
    if (colon == std::string::npos) continue;
    f[line.substr(0, colon)] = line.substr(colon + 2);
  }
  *data_start = pos;
  return f;
}

TEST(WriteGrid, NrrdPlacesTheCellCentres) {
  const DistanceGrid g = small_grid(3);
  const std::string attached = out_path("field.nrrd");
  write_grid_distance(g, attached, false);
  const std::string text = read_all(attached);
  size_t data = 0;
  auto f = parse_nrrd(text, &data);
  EXPECT_EQ(f["type"], "float");
  EXPECT_EQ(f["dimension"], "3");
  EXPECT_EQ(f["space dimension"], "3");
  EXPECT_EQ(f["sizes"], std::to_string(g.spec.n[0]) + " " + std::to_string(g.spec.n[1]) + " " +
                            std::to_string(g.spec.n[2]));
  EXPECT_EQ(f["endian"], "little");
  EXPECT_EQ(f["encoding"], "raw");
  EXPECT_EQ(f["kinds"], "domain domain domain");
  // space directions: h on the diagonal; space origin: the centre of cell (0, 0, 0).
  double h[9], o[3];
  ASSERT_EQ(std::sscanf(f["space directions"].c_str(), "(%lf,%lf,%lf) (%lf,%lf,%lf) (%lf,%lf,%lf)",
                        &h[0], &h[1], &h[2], &h[3], &h[4], &h[5], &h[6], &h[7], &h[8]),
            9);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(h[i], i % 4 == 0 ? g.spec.h : 0.0) << i;
  ASSERT_EQ(std::sscanf(f["space origin"].c_str(), "(%lf,%lf,%lf)", &o[0], &o[1], &o[2]), 3);
  const Vec3 c = g.spec.centre(0, 0, 0);
  EXPECT_EQ(o[0], c.x);
  EXPECT_EQ(o[1], c.y);
  EXPECT_EQ(o[2], c.z);
  ASSERT_EQ(text.size() - data, 4 * g.label.size());
  for (size_t i = 0; i < g.label.size(); ++i) {
    float v;
    std::memcpy(&v, text.data() + data + 4 * i, 4);
    ASSERT_EQ(v, static_cast<float>(g.distance[i])) << i;
  }
  // Detached labels: the header names the .raw beside it, which holds the int32 labels.
  const std::vector<std::string> files = write_grid_labels(g, out_path("labels.nhdr"));
  ASSERT_EQ(files.size(), 2u);
  auto lf = parse_nrrd(read_all(files[0]), &data);
  EXPECT_EQ(lf["type"], "int32");
  EXPECT_EQ(lf["data file"], "grid_labels.raw");
  const std::string raw = read_all(files[1]);
  ASSERT_EQ(raw.size(), 4 * g.label.size());
  EXPECT_EQ(std::memcmp(raw.data(), g.label.data(), raw.size()), 0);
}

TEST(WriteGrid, NrrdIn2D) {
  const DistanceGrid g = small_grid(2);
  const std::string h = nrrd_header(g.spec, GridValueType::kFloat64, "", "");
  size_t data = 0;
  auto f = parse_nrrd(h, &data);
  EXPECT_EQ(f["dimension"], "2");
  EXPECT_EQ(f["sizes"], std::to_string(g.spec.n[0]) + " " + std::to_string(g.spec.n[1]));
  EXPECT_EQ(f["type"], "double");
  EXPECT_EQ(data, h.size());  // ends with the blank line
}

// The scene's units reach the NRRD header ("space units", one per axis, ASCII),
// and no header says units when the scene declared none.
TEST(WriteGrid, NrrdSaysTheScenesUnits) {
  size_t data = 0;
  Scene scene = test::make_scene(3, {test::make_box("b", {0.1, 0.1, 0.1}, {0.4, 0.5, 0.3})});
  GridOptions o;
  o.resolution = 5;
  EXPECT_EQ(compute_grid(scene, o).units, "");
  EXPECT_EQ(
      parse_nrrd(nrrd_header(compute_grid(scene, o).spec, GridValueType::kInt32, "", ""), &data)
          .count("space units"),
      0u);
  scene.units = "mm";
  const DistanceGrid g = compute_grid(scene, o);
  EXPECT_EQ(g.units, "mm");
  for (const std::string& path : write_grid_distance(g, out_path("units.nhdr"), false)) {
    if (!path.ends_with(".nhdr")) continue;
    EXPECT_EQ(parse_nrrd(read_all(path), &data)["space units"], "\"mm\" \"mm\" \"mm\"");
  }
  const std::string attached = read_all(write_grid_labels(g, out_path("units.nrrd"))[0]);
  EXPECT_EQ(parse_nrrd(attached, &data)["space units"], "\"mm\" \"mm\" \"mm\"");
  EXPECT_EQ(
      parse_nrrd(nrrd_header(g.spec, GridValueType::kFloat32, "", "", "µm"), &data)["space units"],
      "\"um\" \"um\" \"um\"");
  const DistanceGrid flat = small_grid(2);
  EXPECT_EQ(parse_nrrd(nrrd_header(flat.spec, GridValueType::kFloat32, "", "", "Å"),
                       &data)["space units"],
            "\"angstrom\" \"angstrom\"");
}

TEST(WriteGrid, UnknownExtensionIsAnError) {
  const DistanceGrid g = small_grid(2);
  try {
    write_grid_distance(g, out_path("field.vtk"), false);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace gvd
