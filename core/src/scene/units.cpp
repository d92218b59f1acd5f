// The length units of a scene: names, aliases, and the one error that rejects the rest.
#include "gvd/scene/units.h"

#include <array>
#include <utility>

namespace gvd::scene {

std::optional<std::string> canonical_units(std::string_view text) {
  // {spelling, canonical name}: every canonical name spells itself.
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 14> kNames = {{
      {"\xC3\x85", "\xC3\x85"},      // Å, U+00C5
      {"\xE2\x84\xAB", "\xC3\x85"},  // Å, U+212B ANGSTROM SIGN
      {"angstrom", "\xC3\x85"},      //
      {"nm", "nm"},                  //
      {"\xC2\xB5m", "\xC2\xB5m"},    // µm, U+00B5 MICRO SIGN
      {"\xCE\xBCm", "\xC2\xB5m"},    // μm, U+03BC GREEK SMALL LETTER MU
      {"um", "\xC2\xB5m"},           //
      {"micron", "\xC2\xB5m"},       //
      {"mm", "mm"},                  //
      {"cm", "cm"},                  //
      {"m", "m"},                    //
      {"km", "km"},                  //
      {"in", "in"},                  //
      {"ft", "ft"},                  //
  }};
  for (const auto& [spelling, name] : kNames) {
    if (text == spelling) return std::string(name);
  }
  return std::nullopt;
}

std::string parse_units(std::string_view text, std::string_view field, ErrorCode code,
                        ErrorLocation where) {
  if (std::optional<std::string> name = canonical_units(text)) return *name;
  std::string given(text.substr(0, 40));
  if (text.size() > 40) given += "...";
  throw Error(code,
              std::string(field) + " must name a length unit, one of " + std::string(kKnownUnits) +
                  ", got \"" + given + "\"",
              std::move(where));
}

std::string units_suffix(std::string_view units) {
  return units.empty() ? std::string() : " " + std::string(units);
}

std::string ascii_units(std::string_view units) {
  if (units == "µm") return "um";
  if (units == "Å") return "angstrom";
  return std::string(units);
}

}  // namespace gvd::scene
