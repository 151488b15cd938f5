// The web dashboard's rules on a real loopback HTTP server in front of a real Coordinator: who
// may look and who may act (client token, viewer token, session cookie, nothing), the login form
// (wrong token, cookie attributes, where it sends the browser, logins from other sites), actions
// that a page of another site could forge, and the JSON and PNG the pages read. The pages
// themselves are tested in a real browser by tests/farm/dashboard_test.py.
#include "coordinator/dashboard.h"
#include "common/farm/build_identity.h"
#include "common/scene/accel.h"

#include "common/farm/http_test_client.h"
#include "coordinator/coordinator_job_test.h"

#include <gtest/gtest.h>

namespace alphorn::coordinator {
namespace {

const std::string kClientToken = "c0c0c0c0c0c0c0c0c0c0c0c0c0c0c0c0";
const std::string kViewerToken = "v1v1v1v1v1v1v1v1v1v1v1v1v1v1v1v1";

TEST(DashboardSessionsTest, TokensGiveTheirRoleAndNothingElse) {
    DashboardSessions sessions(kClientToken, kViewerToken);
    EXPECT_EQ(sessions.roleOfToken(kClientToken), DashboardRole::Operator);
    EXPECT_EQ(sessions.roleOfToken(kViewerToken), DashboardRole::Viewer);
    EXPECT_EQ(sessions.roleOfToken(""), DashboardRole::None);
    EXPECT_EQ(sessions.roleOfToken(kClientToken.substr(0, 31)), DashboardRole::None);
    EXPECT_EQ(sessions.roleOfToken(kClientToken + "0"), DashboardRole::None);
    // Without a viewer token, an empty token is still nobody's.
    DashboardSessions noViewers(kClientToken, "");
    EXPECT_EQ(noViewers.roleOfToken(""), DashboardRole::None);
    EXPECT_THROW(DashboardSessions(kClientToken, kClientToken), Error);
    EXPECT_THROW(DashboardSessions("", kViewerToken), Error);
}

TEST(DashboardSessionsTest, SessionsExpireCloseAndStayBounded) {
    DashboardSessions sessions(kClientToken, kViewerToken);
    const double lifetime = DashboardSessions::kLifetimeSeconds;
    const std::string id = sessions.open(DashboardRole::Viewer, 100);
    EXPECT_EQ(id.size(), 64u);
    EXPECT_EQ(sessions.roleOfSession(id, 100 + lifetime - 1), DashboardRole::Viewer);
    EXPECT_EQ(sessions.roleOfSession(id.substr(1), 100), DashboardRole::None);
    EXPECT_EQ(sessions.roleOfSession("", 100), DashboardRole::None);
    EXPECT_EQ(sessions.roleOfSession(id, 100 + lifetime), DashboardRole::None);
    EXPECT_EQ(sessions.size(), 0u);  // an expired session is forgotten

    const std::string closed = sessions.open(DashboardRole::Operator, 0);
    EXPECT_EQ(sessions.roleOfSession(closed, 1), DashboardRole::Operator);
    sessions.close(closed);
    EXPECT_EQ(sessions.roleOfSession(closed, 1), DashboardRole::None);

    // Beyond the bound, the session closest to expiry (the oldest) makes room.
    const std::string oldest = sessions.open(DashboardRole::Operator, 0);
    for (size_t i = 1; i <= DashboardSessions::kMaxSessions; ++i)
        sessions.open(DashboardRole::Operator, double(i));
    EXPECT_EQ(sessions.size(), DashboardSessions::kMaxSessions);
    EXPECT_EQ(sessions.roleOfSession(oldest, 2000), DashboardRole::None);
}

class DashboardTest : public CoordinatorJobTest {
  protected:
    void SetUp() override {
        CoordinatorJobTest::SetUp();
        start();
    }
    void TearDown() override {
        stop();
        CoordinatorJobTest::TearDown();
    }
    void start() {
        m_coordinator = std::make_unique<Coordinator>(m_options);
        m_server = std::make_unique<farm::HttpServer>(farm::HttpServerOptions{"127.0.0.1:0"});
        m_dashboard = std::make_unique<Dashboard>(*m_coordinator,
                                                  DashboardOptions{kClientToken, kViewerToken});
        m_dashboard->install(*m_server);
        m_server->start();
        m_client = std::make_unique<farm::HttpTestClient>("127.0.0.1", m_server->port());
    }
    void stop() {
        m_server->stop();
        m_dashboard.reset();
        m_coordinator.reset();
    }

    static farm::HttpHeaders bearer(const std::string& token) {
        return {{"Authorization", "Bearer " + token}};
    }
    int getStatus(const std::string& path, const farm::HttpHeaders& headers = {}) {
        auto result = m_client->get(path.c_str(), headers);
        return result ? result->status : -1;
    }
    std::optional<farm::HttpTestResponse> post(const std::string& path,
                                               const farm::HttpHeaders& headers) {
        return m_client->post(path.c_str(), headers, "", "text/plain");
    }
    // Logs in with the form as a browser does; returns the response.
    std::optional<farm::HttpTestResponse> logIn(const std::string& token,
                                                const std::string& next = "",
                                                const std::string& origin = "") {
        farm::HttpHeaders headers;
        if (!origin.empty()) headers.emplace_back("Origin", origin);
        return m_client->postForm("/dashboard/login", headers, {{"token", token}, {"next", next}});
    }
    // The "alphorn_session=..." pair of a login's Set-Cookie.
    static std::string sessionCookie(const std::optional<farm::HttpTestResponse>& login) {
        const std::string header = login->header("Set-Cookie");
        return header.substr(0, header.find(';'));
    }

    std::unique_ptr<Coordinator> m_coordinator;
    std::unique_ptr<farm::HttpServer> m_server;
    std::unique_ptr<Dashboard> m_dashboard;
    std::unique_ptr<farm::HttpTestClient> m_client;
};

TEST_F(DashboardTest, NothingWithoutATokenAndTheViewerCannotAct) {
    for (const char* path : {"/api/jobs", "/api/workers", "/api/job?id=1", "/dashboard/app.js",
                             "/api/job/preview.png?id=1", "/api/session"})
        EXPECT_EQ(getStatus(path), 401) << path;
    EXPECT_EQ(getStatus("/api/jobs", bearer("not-a-token")), 401);
    EXPECT_EQ(getStatus("/api/jobs", {{"Authorization", "Basic " + kClientToken}}), 401);
    // A page without access is the login form, with 401.
    auto page = m_client->get("/dashboard/workers");
    ASSERT_TRUE(page);
    EXPECT_EQ(page->status, 401);
    EXPECT_NE(page->body.find("name=\"token\""), std::string::npos);
    EXPECT_NE(page->body.find("value=\"/dashboard/workers\""), std::string::npos);

    EXPECT_EQ(getStatus("/api/jobs", bearer(kViewerToken)), 200);
    EXPECT_EQ(getStatus("/dashboard/", bearer(kViewerToken)), 200);
    for (const char* action : {"/api/job/pause?id=1", "/api/job/delete?id=1",
                               "/api/job/priority?id=1&priority=3", "/api/worker/drain?id=1"})
        EXPECT_EQ(post(action, bearer(kViewerToken))->status, 403) << action;
    // The client token reaches the coordinator, which answers for the job.
    auto unknown = post("/api/job/pause?id=99", bearer(kClientToken));
    EXPECT_EQ(unknown->status, 404);
    EXPECT_EQ(unknown->body, "no job 99\n");
    EXPECT_EQ(post("/api/job/pause?id=x", bearer(kClientToken))->status, 400);
    EXPECT_EQ(post("/api/job/priority?id=1", bearer(kClientToken))->status, 400);
}

TEST_F(DashboardTest, TheLoginFormSetsAStrictSessionCookie) {
    auto wrong = logIn("not-the-token");
    ASSERT_TRUE(wrong);
    EXPECT_EQ(wrong->status, 401);
    EXPECT_FALSE(wrong->hasHeader("Set-Cookie"));
    EXPECT_NE(wrong->body.find("not valid"), std::string::npos);

    auto login = logIn(kClientToken, "/dashboard/workers");
    ASSERT_TRUE(login);
    EXPECT_EQ(login->status, 303);
    EXPECT_EQ(login->header("Location"), "/dashboard/workers");
    const std::string setCookie = login->header("Set-Cookie");
    EXPECT_NE(setCookie.find("HttpOnly"), std::string::npos);
    EXPECT_NE(setCookie.find("SameSite=Strict"), std::string::npos);
    EXPECT_EQ(setCookie.find("Secure"), std::string::npos);      // plain HTTP here
    EXPECT_EQ(setCookie.find(kClientToken), std::string::npos);  // never the token itself
    const farm::HttpHeaders cookie{{"Cookie", sessionCookie(login)}};
    auto session = m_client->get("/api/session", cookie);
    EXPECT_EQ(session->body, "{\"role\":\"operator\"}");

    // After a login the browser goes to a dashboard page of this server, nowhere else.
    for (const char* next : {"https://elsewhere.example/", "//elsewhere.example/", "/metrics"})
        EXPECT_EQ(logIn(kClientToken, next)->header("Location"), "/dashboard/") << next;
    // A login posted by another site's page is refused; one from this page is not.
    EXPECT_EQ(logIn(kClientToken, "", "https://elsewhere.example")->status, 403);
    EXPECT_EQ(
        logIn(kClientToken, "", "http://127.0.0.1:" + std::to_string(m_server->port()))->status,
        303);

    auto viewer = logIn(kViewerToken);
    auto viewerSession = m_client->get("/api/session", {{"Cookie", sessionCookie(viewer)}});
    EXPECT_EQ(viewerSession->body, "{\"role\":\"viewer\"}");
}

TEST_F(DashboardTest, ActionsWithTheCookieNeedTheDashboardsHeader) {
    const std::string cookie = sessionCookie(logIn(kClientToken));
    // What a form on another site could send: the cookie alone.
    EXPECT_EQ(post("/api/job/pause?id=99", {{"Cookie", cookie}})->status, 403);
    // The dashboard's own script adds the header; the request reaches the coordinator.
    EXPECT_EQ(
        post("/api/job/pause?id=99", {{"Cookie", cookie}, {"X-Alphorn-Dashboard", "1"}})->status,
        404);
    // A bearer token, which no other site's page can attach, needs no header.
    EXPECT_EQ(post("/api/job/pause?id=99", bearer(kClientToken))->status, 404);
    // Logging out ends the session.
    EXPECT_EQ(post("/dashboard/logout", {{"Cookie", cookie}, {"X-Alphorn-Dashboard", "1"}})->status,
              200);
    EXPECT_EQ(getStatus("/api/jobs", {{"Cookie", cookie}}), 401);
}

TEST_F(DashboardTest, ServesAJobsStatusHistoryPreviewAndWorkers) {
    const v1::JobStatus job = m_coordinator->submit(upload(*m_coordinator, 4));
    v1::RegisterRequest registration;
    farm::describeThisBuild(registration);
    registration.set_name("dashboard-worker");
    const uint64_t worker = m_coordinator->registerWorker(registration);
    const v1::AcquireWorkResponse held =
        m_coordinator->acquire(worker, std::chrono::steady_clock::now());
    ASSERT_TRUE(held.has_work());

    // The workers page's current unit.
    auto workers = m_client->get("/api/workers", bearer(kViewerToken));
    ASSERT_EQ(workers->status, 200);
    EXPECT_NE(
        workers->body.find("\"held_units\":{\"" + std::to_string(worker) +
                           "\":[{\"job_id\":" + std::to_string(job.job_id()) +
                           ",\"unit_index\":" + std::to_string(held.unit().unit_index()) + "}]}"),
        std::string::npos)
        << workers->body;

    // Every unit rendered and merged: 4 passes, so one estimate at 4 passes.
    std::string compressed;
    m_coordinator->report(render(held, worker, compressed), compressed);
    for (;;) {
        const v1::AcquireWorkResponse lease =
            m_coordinator->acquire(worker, std::chrono::steady_clock::now());
        if (!lease.has_work()) break;
        m_coordinator->report(render(lease, worker, compressed), compressed);
    }
    const std::string path = "/api/job?id=" + std::to_string(job.job_id());
    auto status = m_client->get(path.c_str(), bearer(kClientToken));
    ASSERT_EQ(status->status, 200);
    EXPECT_NE(status->body.find("\"state\":\"JOB_STATE_DONE\""), std::string::npos);
    const std::vector<Dashboard::EstimatePoint> history = m_dashboard->history(job.job_id());
    ASSERT_EQ(history.size(), 1u);
    EXPECT_EQ(history[0].passes, 4u);
    EXPECT_GT(history[0].relativeRmse, 0);
    EXPECT_NE(status->body.find("\"history\":[{\"passes\":4,\"relative_rmse\":"),
              std::string::npos);
    EXPECT_NE(status->body.find("JOB_EVENT_FINISHED"), std::string::npos);

    // The preview: a PNG of the job's size (IHDR: width and height, big-endian, at byte 16).
    auto png = m_client->get(("/api/job/preview.png?id=" + std::to_string(job.job_id())).c_str(),
                             bearer(kViewerToken));
    ASSERT_EQ(png->status, 200);
    EXPECT_EQ(png->header("Content-Type"), "image/png");
    ASSERT_GT(png->body.size(), 24u);
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
    auto be32 = [&](size_t at) {
        uint32_t value = 0;
        for (size_t i = 0; i < 4; ++i) value = value << 8 | uint8_t(png->body[at + i]);
        return value;
    };
    EXPECT_EQ(be32(16), 40u);
    EXPECT_EQ(be32(20), 30u);
    EXPECT_EQ(getStatus("/api/job/preview.png?id=77", bearer(kClientToken)), 404);
}

TEST_F(DashboardTest, ActionsCallTheCoordinator) {
    const v1::JobStatus job = m_coordinator->submit(upload(*m_coordinator, 4));
    const std::string id = std::to_string(job.job_id());
    auto paused = post("/api/job/pause?id=" + id, bearer(kClientToken));
    ASSERT_EQ(paused->status, 200);
    EXPECT_TRUE(m_coordinator->listJobs(job.job_id()).at(0).paused());
    EXPECT_NE(paused->body.find("\"paused\":true"), std::string::npos);
    EXPECT_EQ(post("/api/job/priority?id=" + id + "&priority=-4", bearer(kClientToken))->status,
              200);
    EXPECT_EQ(m_coordinator->listJobs(job.job_id()).at(0).settings().priority(), -4);
    EXPECT_EQ(post("/api/job/resume?id=" + id, bearer(kClientToken))->status, 200);
    EXPECT_FALSE(m_coordinator->listJobs(job.job_id()).at(0).paused());
    // Retry of a running job: the coordinator's refusal, as 409 with its reason.
    auto retry = post("/api/job/retry?id=" + id, bearer(kClientToken));
    EXPECT_EQ(retry->status, 409);
    EXPECT_FALSE(retry->body.empty());
    EXPECT_EQ(post("/api/job/cancel?id=" + id, bearer(kClientToken))->status, 200);
    EXPECT_EQ(m_coordinator->listJobs(job.job_id()).at(0).state(), v1::JOB_STATE_CANCELLED);
    EXPECT_EQ(post("/api/job/retry?id=" + id, bearer(kClientToken))->status, 200);
    EXPECT_EQ(m_coordinator->listJobs(job.job_id()).at(0).state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(post("/api/job/delete?id=" + id, bearer(kClientToken))->status, 200);
    EXPECT_THROW(m_coordinator->listJobs(job.job_id()), FarmError);

    v1::RegisterRequest registration;
    farm::describeThisBuild(registration);
    const uint64_t worker = m_coordinator->registerWorker(registration);
    const std::string workerId = std::to_string(worker);
    EXPECT_EQ(post("/api/worker/drain?id=" + workerId, bearer(kClientToken))->status, 200);
    EXPECT_TRUE(m_coordinator->listWorkers(true).at(0).draining());
    EXPECT_EQ(post("/api/worker/undrain?id=" + workerId, bearer(kClientToken))->status, 200);
    EXPECT_FALSE(m_coordinator->listWorkers(true).at(0).draining());
    EXPECT_EQ(post("/api/worker/drain?id=9999", bearer(kClientToken))->status, 404);
}

// The page sends one request id per click of Retry or Delete, and the same id when it repeats
// the request: the coordinator acts on the first and answers the others as it answered it, also
// after a restart.
TEST_F(DashboardTest, RetryAndDeleteWithARequestIdActOnceAcrossARestart) {
    const uint64_t jobId = m_coordinator->submit(upload(*m_coordinator, 4)).job_id();
    const std::string id = std::to_string(jobId);
    m_coordinator->cancel(jobId);
    const std::string retryPath = "/api/job/retry?id=" + id + "&request_id=retry-1_A";
    auto first = post(retryPath, bearer(kClientToken));
    ASSERT_EQ(first->status, 200) << first->body;
    EXPECT_NE(first->body.find("\"state\":\"JOB_STATE_RUNNING\""), std::string::npos);
    // Cancelled again: a second retry would run it again, the repeated request does not.
    m_coordinator->cancel(jobId);
    auto repeated = post(retryPath, bearer(kClientToken));
    ASSERT_EQ(repeated->status, 200) << repeated->body;
    EXPECT_EQ(repeated->body, first->body);
    EXPECT_EQ(m_coordinator->listJobs(jobId).at(0).state(), v1::JOB_STATE_CANCELLED);

    m_coordinator->stop();
    stop();
    start();
    repeated = post(retryPath, bearer(kClientToken));
    ASSERT_EQ(repeated->status, 200) << repeated->body;
    EXPECT_EQ(repeated->body, first->body);
    EXPECT_EQ(m_coordinator->listJobs(jobId).at(0).state(), v1::JOB_STATE_CANCELLED);
    // Another click is another id: it retries.
    EXPECT_EQ(post("/api/job/retry?id=" + id + "&request_id=retry-2", bearer(kClientToken))->status,
              200);
    EXPECT_EQ(m_coordinator->listJobs(jobId).at(0).state(), v1::JOB_STATE_RUNNING);

    // Delete: the repeated request finds the job gone and answers as the first, not 404.
    const std::string deletePath = "/api/job/delete?id=" + id + "&request_id=delete-1";
    auto deleted = post(deletePath, bearer(kClientToken));
    ASSERT_EQ(deleted->status, 200) << deleted->body;
    EXPECT_THROW(m_coordinator->listJobs(jobId), FarmError);
    auto deletedAgain = post(deletePath, bearer(kClientToken));
    ASSERT_EQ(deletedAgain->status, 200) << deletedAgain->body;
    EXPECT_EQ(deletedAgain->body, deleted->body);
    m_coordinator->stop();
    stop();
    start();
    deletedAgain = post(deletePath, bearer(kClientToken));
    ASSERT_EQ(deletedAgain->status, 200) << deletedAgain->body;
    EXPECT_EQ(deletedAgain->body, deleted->body);
    // Without an id (an older page, curl) a repeated delete finds no job.
    EXPECT_EQ(post("/api/job/delete?id=" + id, bearer(kClientToken))->status, 404);
}

TEST_F(DashboardTest, ABadRequestIdIsRefusedNamingTheParameter) {
    const uint64_t jobId = m_coordinator->submit(upload(*m_coordinator, 4)).job_id();
    m_coordinator->cancel(jobId);
    const std::string id = std::to_string(jobId);
    for (const std::string action : {"retry", "delete"})
        for (const std::string& bad :
             std::vector<std::string>{"", std::string(65, 'a'), "a%20b", "a%2Fb", "%C3%A9"}) {
            auto answer = post("/api/job/" + action + "?id=" + id + "&request_id=" + bad,
                               bearer(kClientToken));
            EXPECT_EQ(answer->status, 400) << action << " " << bad;
            EXPECT_NE(answer->body.find("the parameter request_id must be 1 to 64 characters"),
                      std::string::npos)
                << answer->body;
        }
    // Nothing was done: the job is still there, cancelled.
    EXPECT_EQ(m_coordinator->listJobs(jobId).at(0).state(), v1::JOB_STATE_CANCELLED);
    EXPECT_EQ(post("/api/job/retry?id=" + id + "&request_id=" + std::string(64, 'a'),
                   bearer(kClientToken))
                  ->status,
              200);
}

}  // namespace
}  // namespace alphorn::coordinator
