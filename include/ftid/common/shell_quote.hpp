#pragma once
// Quoting of suggested commands, so that every command ftid prints can be pasted into a shell
// (issue 21: `--model paper+harmonic(q6,1)` unquoted is a shell syntax error).
#include <algorithm>
#include <string>

namespace ftid {

/// One word for the shell: returned unchanged when it holds only characters no POSIX shell treats
/// specially (letters, digits, + - _ . , / = : @ %), else in single quotes (a ' inside as '\'').
inline std::string shellQuote(const std::string& word) {
  const bool safe = !word.empty() && std::all_of(word.begin(), word.end(), [](char ch) {
    const auto c = static_cast<unsigned char>(ch);
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
           std::string("+-_.,/=:@%").find(ch) != std::string::npos;
  });
  if (safe) return word;
  std::string out = "'";
  for (char ch : word) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

}  // namespace ftid
