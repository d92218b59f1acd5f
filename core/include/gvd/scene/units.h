#pragma once

// The length units a scene may declare: their canonical names and aliases, parsing (an unknown
// unit throws gvd::Error naming the field and listing the known units), and how a unit is
// printed. Units are a label only: no coordinate is ever converted.

#include <optional>
#include <string>
#include <string_view>

#include "gvd/common/error.h"

namespace gvd::scene {

/// The length units a scene may declare (docs/FORMATS.md, "Units"). They are a label that
/// travels with the scene to every reported length (the graph JSON, query answers, the saved
/// result, the GLB's asset extras, the job status): no coordinate is ever converted. The
/// canonical names, smallest first: "Å", "nm", "µm" (U+00B5), "mm", "cm", "m", "km", "in",
/// "ft". No units (an empty string) is the default: then nothing says a unit.
inline constexpr std::string_view kKnownUnits = "Å, nm, µm (or um), mm, cm, m, km, in, ft";

/// The canonical name of a unit, or nullopt when `text` names none of them. Exact and
/// case-sensitive ("Mm" is a megametre, not a millimetre); aliases: "um", "μm" (Greek mu,
/// U+03BC) and "micron" -> "µm", "angstrom" and "Å" (U+212B) -> "Å".
std::optional<std::string> canonical_units(std::string_view text);

/// canonical_units(text), or gvd::Error{code, where} whose detail names `field` (e.g.
/// "\"units\"", "--units", "parameter \"units\"") and lists the known units; the value
/// given is quoted, cut to 40 bytes.
std::string parse_units(std::string_view text, std::string_view field, ErrorCode code,
                        ErrorLocation where = {});

/// What follows a length when it is printed: " mm" (a space and the unit), "" without units.
std::string units_suffix(std::string_view units);

/// A canonical unit name in ASCII, for headers that must be (NRRD, HTTP): "µm" -> "um",
/// "Å" -> "angstrom", the others as they are.
std::string ascii_units(std::string_view units);

}  // namespace gvd::scene
