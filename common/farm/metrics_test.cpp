// The metric events reach the exposition text, each daemon's registry holds only its own
// families, and /metrics is served with and without a token as configured.
#include "common/farm/metrics.h"

#include "common/farm/http_server.h"
#include "common/farm/http_test_client.h"

#include <gtest/gtest.h>
#include <prometheus/collectable.h>

#include <sstream>

namespace alphorn::farm {
namespace {

const std::string kToken = "0123456789abcdef0123456789abcdef";

// The value of the sample named exactly `series` (name and labels) in exposition text; -1 when
// absent.
double sample(const std::string& text, const std::string& series) {
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind(series + " ", 0) == 0) return std::stod(line.substr(series.size() + 1));
    return -1;
}

std::string coordinatorText() {
    return metricsText({CoordinatorMetrics::registry()});
}

std::string workerText() {
    return metricsText({WorkerMetrics::registry()});
}

TEST(MetricsTest, CoordinatorEventsCountInTheirFamilies) {
    const std::string before = coordinatorText();
    CoordinatorMetrics::unitLeased(false);
    CoordinatorMetrics::unitLeased(true);
    CoordinatorMetrics::unitMerged(4 * 3 * 2);
    CoordinatorMetrics::unitFailed(CoordinatorMetrics::FailureCause::LeaseExpired);
    CoordinatorMetrics::checkpointWritten(0.004, 1000);
    CoordinatorMetrics::blobStored(77);
    const std::string after = coordinatorText();
    const auto delta = [&](const std::string& series) {
        return sample(after, series) - sample(before, series);
    };
    EXPECT_EQ(delta("alphorn_units_leased_total"), 2);
    EXPECT_EQ(delta("alphorn_units_leased_again_total"), 1);
    EXPECT_EQ(delta("alphorn_units_merged_total"), 1);
    EXPECT_EQ(delta("alphorn_samples_merged_total"), 24);
    EXPECT_EQ(delta("alphorn_units_failed_total{cause=\"lease_expired\"}"), 1);
    EXPECT_EQ(delta("alphorn_units_failed_total{cause=\"worker_error\"}"), 0);
    EXPECT_EQ(delta("alphorn_checkpoint_write_seconds_count"), 1);
    // 4 ms falls in the bucket up to 6.25 ms, not in the one up to 2.5 ms.
    EXPECT_EQ(delta("alphorn_checkpoint_write_seconds_bucket{le=\"0.00625\"}"), 1);
    EXPECT_EQ(delta("alphorn_checkpoint_write_seconds_bucket{le=\"0.0025\"}"), 0);
    EXPECT_EQ(delta("alphorn_checkpoint_written_bytes_total"), 1000);
    EXPECT_EQ(delta("alphorn_blob_uploaded_bytes_total"), 77);
    EXPECT_NE(after.find("# TYPE alphorn_units_merged_total counter"), std::string::npos);
    EXPECT_NE(after.find("alphorn_build_info{version=\"" ALPHORN_VERSION "\"} 1"),
              std::string::npos);
}

TEST(MetricsTest, WorkerEventsCountInTheirFamilies) {
    const std::string before = workerText();
    WorkerMetrics::unitRendered(0.5, 64, 1000);
    WorkerMetrics::passDataBuilt(2048);
    WorkerMetrics::resultDelivered(WorkerMetrics::Delivery::Discarded, 0.01);
    WorkerMetrics::resultDelivered(WorkerMetrics::Delivery::Abandoned, 60);
    const std::string after = workerText();
    const auto delta = [&](const std::string& series) {
        return sample(after, series) - sample(before, series);
    };
    EXPECT_EQ(delta("alphorn_worker_units_rendered_total"), 1);
    EXPECT_EQ(delta("alphorn_worker_samples_total"), 64);
    EXPECT_EQ(delta("alphorn_worker_rays_total"), 1000);
    EXPECT_EQ(delta("alphorn_worker_photons_traced_total"), 2048);
    EXPECT_EQ(delta("alphorn_worker_results_total{outcome=\"discarded\"}"), 1);
    EXPECT_EQ(delta("alphorn_worker_results_total{outcome=\"abandoned\"}"), 1);
    // An abandoned result was never answered: only the discarded one has a delivery time.
    EXPECT_EQ(delta("alphorn_worker_delivery_seconds_count"), 1);
}

TEST(MetricsTest, EachDaemonServesOnlyItsOwnFamilies) {
    CoordinatorMetrics::unitHandedBack();
    WorkerMetrics::unitFailed();
    EXPECT_EQ(coordinatorText().find("alphorn_worker_"), std::string::npos);
    EXPECT_EQ(workerText().find("alphorn_units_"), std::string::npos);
}

TEST(MetricsTest, MetricsAreServedWithATokenOrAnonymouslyWhenAllowed) {
    CoordinatorMetrics::unitHandedBack();
    WorkerMetrics::unitFailed();
    HttpServer guarded({"127.0.0.1:0"});
    serveMetrics(guarded, {CoordinatorMetrics::registry()}, {{kToken}});
    guarded.start();
    HttpTestClient guardedClient("127.0.0.1", guarded.port());
    EXPECT_EQ(guardedClient.get("/metrics")->status, 401);
    auto scraped = guardedClient.get("/metrics", {{"Authorization", "Bearer " + kToken}});
    ASSERT_TRUE(scraped);
    EXPECT_EQ(scraped->status, 200);
    EXPECT_EQ(scraped->header("Content-Type"), "text/plain; version=0.0.4; charset=utf-8");
    EXPECT_GE(sample(scraped->body, "alphorn_units_handed_back_total"), 1);

    HttpServer open({"127.0.0.1:0"});
    serveMetrics(open, {WorkerMetrics::registry()}, {{}, true});
    open.start();
    HttpTestClient openClient("127.0.0.1", open.port());
    auto anonymous = openClient.get("/metrics");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 200);
    EXPECT_GE(sample(anonymous->body, "alphorn_worker_units_failed_total"), 1);
}

}  // namespace
}  // namespace alphorn::farm
