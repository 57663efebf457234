#pragma once
// JSON output through nlohmann-json (Debian's nlohmann-json3-dev), with the one policy every JSON
// ftid writes follows (docs/identification.md "Outputs", docs/analyze.md):
//  - numbers: the shortest text that reads back as the same double (round trip; at most
//    max_digits10 = 17 significant digits);
//  - non-finite numbers: null (each output documents what null means there);
//  - object keys keep the order in which they are added (ordered_json);
//  - strings are UTF-8; a byte that is not valid UTF-8 (a file name, say) becomes U+FFFD, so the
//    output is always valid JSON.
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace ftid {

using Json = nlohmann::ordered_json;

/// A number, or null if it is not finite.
inline Json jsonNumber(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

/// The text of `j`: one line (indent < 0) or indented by `indent` spaces per level.
inline std::string jsonText(const Json& j, int indent = -1) {
  return j.dump(indent, ' ', false, Json::error_handler_t::replace);
}

}  // namespace ftid
