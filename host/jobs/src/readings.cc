#include "mlp/jobs/readings.h"

#include <algorithm>

namespace mlp::jobs {

const Reading* Find(const Readings& readings, const std::string& name) {
  const auto it = std::find_if(readings.begin(), readings.end(),
                               [&](const Reading& r) { return r.name == name; });
  return it == readings.end() ? nullptr : &*it;
}

void Set(Readings* readings, Reading reading) {
  const auto it = std::find_if(readings->begin(), readings->end(),
                               [&](const Reading& r) { return r.name == reading.name; });
  if (it == readings->end())
    readings->push_back(std::move(reading));
  else
    *it = std::move(reading);
}

}  // namespace mlp::jobs
