#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "pipeline/flow/validation.h"

namespace mesorock::pipeline {

namespace {
const char* comparison_text(Comparison c) {
  switch (c) {
    case Comparison::Within:
      return "within";
    case Comparison::AtLeast:
      return "at_least";
    case Comparison::AtMost:
      return "at_most";
  }
  return "within";
}
}  // namespace

std::string format_case_text(const CaseResult& r) {
  std::ostringstream s;
  s << "case " << r.name << "\n";
  s << std::left << std::setw(48) << "quantity" << std::right << std::setw(14) << "measured"
    << std::setw(12) << "error" << std::setw(14) << "reference" << std::setw(12) << "tolerance"
    << "  result\n";
  for (const auto& q : r.quantities) {
    std::string ref;
    {
      std::ostringstream t;
      t << std::setprecision(5);
      if (q.comparison == Comparison::AtLeast) t << ">= ";
      if (q.comparison == Comparison::AtMost) t << "<= ";
      t << q.reference;
      ref = t.str();
    }
    s << std::left << std::setw(48) << q.name << std::right << std::setprecision(6) << std::setw(14)
      << q.measured << std::setw(12) << std::setprecision(2) << q.error << std::setw(14) << ref
      << std::setw(12) << std::setprecision(3) << q.tolerance << "  " << (q.pass ? "pass" : "FAIL")
      << "\n";
  }
  for (const auto& q : r.quantities)
    s << "  reference for '" << q.name << "': " << q.source << "\n";
  for (const auto& n : r.notes) s << "note: " << n << "\n";
  s << std::setprecision(3) << r.name << ": " << (r.pass() ? "PASS" : "FAIL") << " (" << r.seconds
    << " s)\n";
  return s.str();
}

std::string format_case_json(const CaseResult& r) {
  nlohmann::json j;
  j["case"] = r.name;
  j["pass"] = r.pass();
  j["seconds"] = r.seconds;
  j["quantities"] = nlohmann::json::array();
  for (const auto& q : r.quantities) {
    j["quantities"].push_back({{"name", q.name},
                               {"measured", q.measured},
                               {"error", q.error},
                               {"reference", q.reference},
                               {"tolerance", q.tolerance},
                               {"comparison", comparison_text(q.comparison)},
                               {"source", q.source},
                               {"pass", q.pass}});
  }
  j["notes"] = r.notes;
  return j.dump();
}

}  // namespace mesorock::pipeline
