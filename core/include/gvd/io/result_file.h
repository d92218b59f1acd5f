#pragma once

// The result file: save_result and load_result write and read a finished GvdResult as a
// versioned little-endian binary file (layout below), written atomically and checked against its
// checksum on load; failures throw gvd::Error saying what is wrong. Also the JSON summary that
// `gvd info` prints, and ResultStats to and from JSON.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/result/gvd_result.h"

namespace gvd::io {

/// Version of the result file layout this build writes and reads.
inline constexpr uint32_t kResultFormatVersion = 1;

/// What the fixed header of a result file says.
struct ResultFileHeader {
  uint32_t format_version = 0;
  uint32_t algorithm_version = 0;  ///< kAlgorithmVersion of the build that computed the result
};

/// Saves a finished result as a versioned little-endian binary file, written atomically
/// (temporary file + rename; gvd::Error{kIo} on failure). Layout:
///
///   header   8-byte magic "GVDRES\0\1", u32 format version (kResultFormatVersion),
///            u32 kAlgorithmVersion
///   sections u32 tag (4 ASCII chars in file order) + u64 payload length + payload:
///            "SCNE" scene JSON (scene_to_json, with "units" when the scene declares them:
///                   readers before units ignore the key) + warnings JSON array
///            "DOMN" dimension, origin xyz, side[, axis x, y, z as 3 x xyz: only when the
///                   octree's frame is not the user's axes; older readers reject those]
///            "OCTR" dimension, max_depth, depth, leaf count, code[], level[], object[]
///            "DIST" dimension, key[], label[], point[], closest[] (xyz doubles), exact[],
///                   exact_count, exact_reused, exact_near_gvd
///            "GVD " dimension, cell count, per cell: object, positions[] (xyz doubles),
///                   other[], clearance[], indices[]
///            "GRPH" node_count, edge count, a[], b[], area[], min_clearance[],
///                   tightest_point[] (xyz doubles)
///            "GAPS" (optional: older files have none, and load with every gap -1 = not
///                   measured) per graph edge gap[] (double), touching[] (u8, 0 or 1)
///            "STAT" ResultStats as JSON text
///   trailer  u64 FNV-1a-64 of every preceding byte.
///
/// Scalars are u32 (dimension, depths, ids), u64 (counts) or IEEE-754 doubles; an array is a
/// u64 element count followed by the packed elements; a string is a u64 byte count followed by
/// the bytes. Not stored (rebuilt by load_result): the unit geometry, the vertex key -> index
/// map, and the octree's leaf -> simplex incidence (which is left empty). The whole file is
/// assembled in memory first: O(size of the result) time and extra memory.
void save_result(const result::GvdResult& result, const std::string& path);

/// The bytes save_result writes (for stores that are not plain files).
std::vector<uint8_t> result_to_bytes(const result::GvdResult& result);

/// Loads a result saved by save_result. gvd::Error{kIo} when the file cannot be read, else as
/// load_result_bytes.
result::GvdResult load_result(const std::string& path);

/// Parses the bytes of a result file. Throws gvd::Error{kInvalidArgument} with a detail that
/// says what is wrong and where: not a gvd result (bad magic), an unsupported format version,
/// a checksum mismatch (truncated or corrupted file), a section running past the end, an array
/// count that does not fit the section, a missing or duplicate section, or inconsistent data
/// (array sizes that disagree, indices out of range, unsorted keys). Unknown sections are
/// skipped. Results of another kAlgorithmVersion are loaded as they are (see
/// read_result_header). Rebuilds the unit geometry (make_unit_geometry) and the vertex index
/// (the leaves' simplex and vertex lists, acceleration data of the computation, are not
/// stored). O(size) plus the geometry mapping.
result::GvdResult load_result_bytes(std::span<const uint8_t> bytes);

/// Reads and checks only the fixed header (magic and format version), e.g. to tell which
/// algorithm version computed a stored result. Throws like load_result_bytes.
ResultFileHeader read_result_header(std::span<const uint8_t> bytes);

/// The summary `gvd info` prints and the server's job status reuses, as compact JSON:
/// {"dimension","objects","simplices"[,"units"],"domain":{"origin":[x,y(,z)],"side"[,"axes"]},"backend","threads",
/// "max_depth","depth","leaves","vertices","octree_bytes","bytes_per_leaf","distance_bytes",
/// "gvd_simplices","graph_edges","refine_rounds","ambiguous_cells_left","touching_leaves",
/// "total_seconds","stages":[{"name","seconds","bytes","items"}],
/// "warnings":[{"kind","object","count","detail"}]}. Sizes in bytes, times in seconds, the
/// domain in user units ("units": the scene's, only when it declares them).
std::string result_info_json(const result::GvdResult& result);

/// ResultStats as JSON (the "STAT" section): the fields of ResultStats by name, stages as an
/// array of {"name","seconds","bytes","items"}.
std::string stats_to_json(const result::ResultStats& stats);

/// Inverse of stats_to_json; missing fields keep their defaults. gvd::Error{kInvalidArgument}
/// when the text is not a JSON object or a field has the wrong type.
result::ResultStats stats_from_json(std::string_view text);

}  // namespace gvd::io
