// The coordinator's web dashboard, served on the daemon's HTTP server (--http-listen) when
// started with --dashboard: pages for jobs, one job (live preview, convergence chart, event log,
// actions) and workers (drain, undrain), and the JSON API they use (docs/dashboard.md).
//
// Access: the client token acts, the optional viewer token only looks, and nothing is open to
// anyone but the login form. A browser logs in with a token (a session cookie, HttpOnly,
// SameSite=Strict); scripts send `Authorization: Bearer <token>`. An action (POST) carried by
// the cookie must also carry the header X-Alphorn-Dashboard, which a page of another site cannot
// send without a CORS preflight this server never approves: no action can be forged cross-site.
//
// Every action calls the same Coordinator method as the matching gRPC call of the CLI.
#pragma once

#include "common/farm/http_server.h"
#include "coordinator/coordinator.h"
#include "coordinator/dashboard_sessions.h"

#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace alphorn::coordinator {

struct DashboardOptions {
    std::string clientToken;       // may look and act
    std::string viewerToken = {};  // may look; empty: no viewers
    bool tls = false;              // served over HTTPS: the cookie is marked Secure
    double samplingSeconds = 0.5;  // how often the estimate history is sampled
};

class Dashboard {
  public:
    Dashboard(Coordinator& coordinator, DashboardOptions options);
    ~Dashboard();
    Dashboard(const Dashboard&) = delete;
    Dashboard& operator=(const Dashboard&) = delete;

    // Adds the dashboard's routes (before the server starts).
    void install(farm::HttpServer& server);
    // Starts and stops the thread that records each job's error estimates as they come.
    void start();
    void stop();

    // One point of a job's convergence: the error estimate made at `passes` passes.
    struct EstimatePoint {
        uint32_t passes = 0;
        double relativeRmse = 0;
    };
    // The estimates seen for the job by this process, by passes.
    std::vector<EstimatePoint> history(uint64_t jobId) const;
    // Notes the estimates of these statuses (the sampling thread and the jobs API answers call it).
    void record(const std::vector<v1::JobStatus>& statuses);

  private:
    // What a request may do: the role of its bearer token or session cookie.
    struct Caller {
        DashboardRole role = DashboardRole::None;
        bool byCookie = false;
    };
    // Page: GET, a caller without access gets the login form (401). Api: GET, 401 as text.
    // Action: POST by the operator only. Session: POST by either role (logging out).
    enum class RouteKind { Page, Api, Action, Session };
    using Handler = std::function<void(const farm::HttpRequest&, farm::HttpResponse&)>;
    Caller identify(const farm::HttpRequest& request);
    // Adds a route whose handler runs only for a caller the kind allows; every dashboard route
    // except the login form is added through here.
    void route(farm::HttpServer& server, const std::string& path, RouteKind kind, Handler handler);
    void serveAsset(farm::HttpResponse& response, const std::string& name) const;
    void login(const farm::HttpRequest& request, farm::HttpResponse& response);
    void loginPage(farm::HttpResponse& response, int status, const std::string& problem,
                   const std::string& next) const;

    void jobsJson(farm::HttpResponse& response);
    void jobJson(const farm::HttpRequest& request, farm::HttpResponse& response);
    void previewPng(const farm::HttpRequest& request, farm::HttpResponse& response);
    void workersJson(farm::HttpResponse& response);
    void jobAction(const farm::HttpRequest& request, farm::HttpResponse& response,
                   const std::string& action);
    void workerAction(const farm::HttpRequest& request, farm::HttpResponse& response,
                      bool draining);
    void samplingLoop();

    Coordinator& m_coordinator;
    DashboardOptions m_options;
    DashboardSessions m_sessions;
    mutable std::mutex m_historyMutex;
    std::map<uint64_t, std::vector<EstimatePoint>> m_history;  // by job id, by passes
    std::mutex m_samplingMutex;
    std::condition_variable m_samplingWake;
    bool m_stopping = false;
    std::thread m_sampling;
};

}  // namespace alphorn::coordinator
