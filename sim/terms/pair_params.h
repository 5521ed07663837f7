#pragma once
// The per-pair parameters as each term sees them. A term (sim/terms/*.h) reads its keys from a
// scene's [[pairs]] entry (PairEntry), keeps them in the model's PairSpec (sim/model.h) and fills
// its fields of the device table's PairParams; the scene reader and the table builder loop over
// the selected terms (sim/terms.h) and name none of them.
#include <string>

namespace mesorock::sim {

// Per type-pair parameters, stored in a symmetric ntypes x ntypes table. One struct for every
// term, so the pair loop loads one row; the comment names the term that fills each field.
template <class Real>
struct PairParams {
  Real A = 0;      // conservative amplitude (dpd: a = A > 0 repels; mdpd: A < 0 attracts)
  Real B = 0;      // many-body repulsion amplitude (mdpd), B > 0
  Real gamma = 0;  // dissipation coefficient (dpd thermostat)
  Real sigma = 0;  // random amplitude, sigma^2 = 2 gamma kBT (dpd thermostat)
};

// One [[pairs]] entry of a scene, as a term reads it. pipeline/scene.cpp implements it: the
// errors it throws name the file and the key, like every other scene error.
class PairEntry {
 public:
  virtual ~PairEntry() = default;
  // The number under key; an error when it is missing or not a finite number.
  virtual double require_number(const char* key) = 0;
  // An error ("not allowed " + why) when the entry gives key.
  virtual void forbid(const char* key, const std::string& why) = 0;
  // The error "rule (got value)" for key.
  [[noreturn]] virtual void reject(const char* key, const std::string& rule, double value) = 0;
};

}  // namespace mesorock::sim
