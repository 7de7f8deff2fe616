#include "mlp/jobs/readings.h"

#include <algorithm>

namespace mlp::jobs {

Reading* Find(Readings* readings, const std::string& name) {
  const auto it = std::find_if(readings->begin(), readings->end(),
                               [&](const Reading& r) { return r.name == name; });
  return it == readings->end() ? nullptr : &*it;
}

const Reading* Find(const Readings& readings, const std::string& name) {
  return Find(const_cast<Readings*>(&readings), name);  // NOLINT: the same search, read only
}

void Set(Readings* readings, Reading reading) {
  if (Reading* r = Find(readings, reading.name))
    *r = std::move(reading);
  else
    readings->push_back(std::move(reading));
}

}  // namespace mlp::jobs
