// The coordinator's metrics that describe its state rather than count events, read from the
// Coordinator at each scrape so they are never out of date: jobs by state, units pending and
// leased, workers by state and the units each merged, the blob store's size. The counted events
// are in common/farm/metrics.h; both are served together on /metrics.
#pragma once

#include <prometheus/collectable.h>

namespace alphorn::coordinator {

class Coordinator;

class CoordinatorStateMetrics : public prometheus::Collectable {
  public:
    explicit CoordinatorStateMetrics(Coordinator& coordinator) : m_coordinator(coordinator) {}
    std::vector<prometheus::MetricFamily> Collect() const override;

  private:
    Coordinator& m_coordinator;
};

}  // namespace alphorn::coordinator
