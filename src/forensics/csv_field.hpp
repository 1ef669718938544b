#pragma once
// One CSV field as RFC 4180 quotes it, made safe for spreadsheets: a field that starts with
// = + - @ or a tab or carriage return is a formula to Excel, LibreOffice and Google Sheets
// (a marker label "=HYPERLINK(...)" would run on opening the evidence table), so it is
// prefixed with an apostrophe, which they show as text (OWASP's CSV injection advice). Such
// fields, and those holding a comma, quote or line break, are quoted with quotes doubled.
#include <string>
#include <string_view>

namespace locard::forensics {

inline std::string csv_field(std::string_view s) {
  const bool formula = !s.empty() && std::string_view("=+-@\t\r").find(s.front()) != std::string_view::npos;
  if (!formula && s.find_first_of(",\"\n\r") == std::string_view::npos) return std::string(s);
  std::string q = formula ? "\"'" : "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace locard::forensics
