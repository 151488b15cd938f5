#include "coordinator/dashboard.h"

#include "common/core/image.h"
#include "common/farm/convert.h"
#include "common/farm/rpc.h"
#include "coordinator/dashboard_assets.h"
#include "coordinator/log.h"
#include "coordinator/services.h"
#include "coordinator/state_db.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_format.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <set>

namespace alphorn::coordinator {

namespace {

constexpr const char* kSessionCookie = "alphorn_session";
// The header the dashboard's own script sends with every action (see dashboard.h).
constexpr const char* kActionHeader = "X-Alphorn-Dashboard";
// A job's history keeps at most this many estimates (decisions are at 4, 8, 16, ... passes
// and the cap, so a job of 2^20 passes has 19).
constexpr size_t kMaxHistoryPoints = 64;

double monotonicSeconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

std::string number(double value) {
    char text[32];
    const auto result = std::to_chars(text, text + sizeof text, value);
    return std::string(text, result.ptr);
}

std::string htmlEscaped(std::string_view text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&#39;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string contentTypeOf(std::string_view name) {
    if (name.ends_with(".html")) return "text/html; charset=utf-8";
    if (name.ends_with(".css")) return "text/css; charset=utf-8";
    if (name.ends_with(".js")) return "text/javascript; charset=utf-8";
    return "application/octet-stream";
}

void plainText(farm::HttpResponse& response, int status, const std::string& text) {
    response.status = status;
    response.setContent(text + "\n", "text/plain; charset=utf-8");
}

void jsonAnswer(farm::HttpResponse& response, const std::string& json) {
    response.status = 200;
    response.setContent(json, "application/json");
}

// The value of a cookie in the request's Cookie header; empty when it has none.
std::string cookieValue(const farm::HttpRequest& request, std::string_view name) {
    const std::string header = request.header("Cookie");
    std::string_view rest = header;
    while (!rest.empty()) {
        const size_t end = std::min(rest.find(';'), rest.size());
        std::string_view pair = rest.substr(0, end);
        rest = end < rest.size() ? rest.substr(end + 1) : std::string_view();
        while (!pair.empty() && pair.front() == ' ') pair.remove_prefix(1);
        if (pair.size() > name.size() && pair.substr(0, name.size()) == name &&
            pair[name.size()] == '=')
            return std::string(pair.substr(name.size() + 1));
    }
    return {};
}

// An unsigned number parameter of the request (?id=7); InvalidArgument when missing or not one.
uint64_t numberParam(const farm::HttpRequest& request, const char* name) {
    const std::string text = request.param(name);
    uint64_t value = 0;
    const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size())
        throw FarmError(FarmError::Kind::InvalidArgument,
                        absl::StrFormat("the parameter %s must be a number (got \"%s\")", name,
                                        text.substr(0, 40)));
    return value;
}

// The request_id parameter of a retry or delete: the page sends one per click and the same again
// when it repeats the request, so that the coordinator acts once (RetryJobRequest.request_id).
// Empty when absent; InvalidArgument when present but not 1 to 64 characters of [0-9A-Za-z_-].
std::string requestIdParam(const farm::HttpRequest& request) {
    if (!request.hasParam("request_id")) return {};
    const std::string text = request.param("request_id");
    constexpr size_t kMaxChars = 64;
    const bool wellFormed =
        !text.empty() && text.size() <= kMaxChars &&
        std::all_of(text.begin(), text.end(), [](char c) {
            return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
        });
    if (!wellFormed)
        throw FarmError(FarmError::Kind::InvalidArgument,
                        absl::StrFormat("the parameter request_id must be 1 to %u characters of "
                                        "0-9, A-Z, a-z, _ and - (got %u bytes)",
                                        kMaxChars, text.size()));
    return text;
}

int httpStatusOf(const std::exception& e) {
    if (auto* farmError = dynamic_cast<const FarmError*>(&e)) {
        switch (farmError->kind) {
            case FarmError::Kind::InvalidArgument:
                return 400;
            case FarmError::Kind::NotFound:
            case FarmError::Kind::UnknownWorker:
                return 404;
            case FarmError::Kind::FailedPrecondition:
                return 409;
            case FarmError::Kind::ResourceExhausted:
            case FarmError::Kind::Unavailable:
            case FarmError::Kind::CallerGone:  // no dashboard action has one; nobody reads it
                return 503;
        }
    }
    if (dynamic_cast<const StorageError*>(&e)) return 503;
    if (dynamic_cast<const Error*>(&e)) return 400;
    return 500;
}

// Where to go after logging in: a dashboard page of this server, never another site.
std::string safeNext(const std::string& next) {
    const bool local =
        next.starts_with("/dashboard") && next.find_first_of("\\\r\n") == std::string::npos;
    return local ? next : "/dashboard/";
}

}  // namespace

Dashboard::Dashboard(Coordinator& coordinator, DashboardOptions options)
    : m_coordinator(coordinator),
      m_options(std::move(options)),
      m_sessions(m_options.clientToken, m_options.viewerToken) {}

Dashboard::~Dashboard() {
    stop();
}

// ---- access ------------------------------------------------------------------------------------

Dashboard::Caller Dashboard::identify(const farm::HttpRequest& request) {
    const std::string authorization = request.header("Authorization");
    if (!authorization.empty()) {
        // A request that names a token is judged by it alone, never by a cookie beside it.
        const std::string_view prefix = "Bearer ";
        if (!authorization.starts_with(prefix)) return {};
        return {m_sessions.roleOfToken(std::string_view(authorization).substr(prefix.size())),
                false};
    }
    return {m_sessions.roleOfSession(cookieValue(request, kSessionCookie), monotonicSeconds()),
            true};
}

void Dashboard::route(farm::HttpServer& server, const std::string& path, RouteKind kind,
                      Handler handler) {
    auto guarded = [this, kind, handler = std::move(handler)](const farm::HttpRequest& request,
                                                              farm::HttpResponse& response) {
        // No page may be framed by another site (the buttons could be clicked through it), and
        // a page runs only its own script.
        response.addHeader("Content-Security-Policy",
                           "default-src 'self'; style-src 'self' 'unsafe-inline'; "
                           "frame-ancestors 'none'; form-action 'self'; base-uri 'none'");
        response.addHeader("X-Frame-Options", "DENY");
        response.addHeader("X-Content-Type-Options", "nosniff");
        response.addHeader("Referrer-Policy", "no-referrer");
        response.addHeader("Cache-Control", "no-store");
        const Caller caller = identify(request);
        const auto refuse = [&](int status, const std::string& text) {
            logWarning(
                "dashboard.refused",
                {field("path", request.path), field("status", status),
                 field("peer", request.remoteAddress + ":" + std::to_string(request.remotePort))});
            plainText(response, status, text);
        };
        if (caller.role == DashboardRole::None) {
            if (kind == RouteKind::Page) {
                // A browser without a session: the login form, which comes back here.
                refuse(401, "");
                loginPage(response, 401, "", request.target);
            } else {
                refuse(401,
                       "401 unauthorized: log in at /dashboard/login or send the header "
                       "Authorization: Bearer <token>");
            }
            response.addHeader("WWW-Authenticate", "Bearer realm=\"alphorn\"");
            return;
        }
        if (kind == RouteKind::Action) {
            if (caller.role != DashboardRole::Operator)
                return refuse(403, "403 forbidden: the viewer token may look but not act");
            if (caller.byCookie && request.header(kActionHeader) != "1")
                return refuse(403, std::string("403 forbidden: an action sent with the session "
                                               "cookie must carry the header ") +
                                       kActionHeader + ": 1");
        }
        if (kind == RouteKind::Session && caller.byCookie && request.header(kActionHeader) != "1")
            return refuse(403, std::string("403 forbidden: missing the header ") + kActionHeader);
        try {
            handler(request, response);
        } catch (const std::exception& e) {
            const int status = httpStatusOf(e);
            if (status >= 500)
                logWarning("dashboard.error",
                           {field("path", request.path), field("error", e.what())});
            plainText(response, status,
                      relativeToStateDirectory(e.what(), m_coordinator.options().stateDirectory));
        }
    };
    // Open at the server's level: `guarded` decides, by bearer token or session cookie, which
    // the server's own check (bearer tokens only) cannot read.
    const farm::RouteAccess checkedHere{{}, true};
    if (kind == RouteKind::Page || kind == RouteKind::Api)
        server.get(path, checkedHere, std::move(guarded));
    else
        server.post(path, checkedHere, std::move(guarded));
}

void Dashboard::loginPage(farm::HttpResponse& response, int status, const std::string& problem,
                          const std::string& next) const {
    const DashboardAsset* asset = findDashboardAsset("login.html");
    std::string page(asset->body);
    auto replace = [&](const std::string& key, const std::string& value) {
        const size_t at = page.find(key);
        if (at != std::string::npos) page.replace(at, key.size(), value);
    };
    replace("{{problem}}", htmlEscaped(problem));
    replace("{{next}}", htmlEscaped(safeNext(next)));
    response.status = status;
    response.setContent(page, "text/html; charset=utf-8");
}

void Dashboard::login(const farm::HttpRequest& request, farm::HttpResponse& response) {
    response.addHeader("Cache-Control", "no-store");
    response.addHeader("X-Frame-Options", "DENY");
    response.addHeader("Content-Security-Policy",
                       "default-src 'self'; style-src 'self' 'unsafe-inline'; "
                       "frame-ancestors 'none'; form-action 'self'; base-uri 'none'");
    const std::string next = request.param("next");
    if (request.method == "GET") return loginPage(response, 200, "", next);
    // A login posted from another site's page would log the browser in with that site's token.
    const std::string origin = request.header("Origin");
    const std::string self =
        std::string(m_options.tls ? "https://" : "http://") + request.header("Host");
    if (!origin.empty() && origin != self) {
        logWarning("dashboard.refused", {field("path", request.path), field("origin", origin)});
        return plainText(response, 403,
                         "403 forbidden: a login from another site (" + origin + ")");
    }
    const DashboardRole role = m_sessions.roleOfToken(request.param("token"));
    if (role == DashboardRole::None) {
        logWarning(
            "dashboard.login_failed",
            {field("peer", request.remoteAddress + ":" + std::to_string(request.remotePort))});
        return loginPage(response, 401, "That token is not valid here.", next);
    }
    const std::string session = m_sessions.open(role, monotonicSeconds());
    std::string cookie = std::string(kSessionCookie) + "=" + session +
                         "; Path=/; HttpOnly; SameSite=Strict; Max-Age=" +
                         std::to_string(int(DashboardSessions::kLifetimeSeconds));
    if (m_options.tls) cookie += "; Secure";
    response.addHeader("Set-Cookie", cookie);
    logInfo("dashboard.login",
            {field("role", role == DashboardRole::Operator ? "operator" : "viewer"),
             field("peer", request.remoteAddress)});
    response.redirect(safeNext(next), 303);
}

void Dashboard::serveAsset(farm::HttpResponse& response, const std::string& name) const {
    const DashboardAsset* asset = findDashboardAsset(name);
    if (!asset) return plainText(response, 404, "404 not found: " + name);
    response.status = 200;
    response.setContent(std::string(asset->body), contentTypeOf(name).c_str());
}

void Dashboard::install(farm::HttpServer& server) {
    // The login form is the one thing open to anyone: it shows a form and checks a token.
    const farm::RouteAccess anyone{{}, true};
    auto login = [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
        this->login(request, response);
    };
    server.get("/dashboard/login", anyone, login);
    server.post("/dashboard/login", anyone, login);

    auto redirect = [](const farm::HttpRequest&, farm::HttpResponse& response) {
        response.redirect("/dashboard/", 303);
    };
    route(server, "/", RouteKind::Page, redirect);
    route(server, "/dashboard", RouteKind::Page, redirect);
    auto page = [this](const std::string& name) {
        return [this, name](const farm::HttpRequest&, farm::HttpResponse& response) {
            serveAsset(response, name);
        };
    };
    route(server, "/dashboard/", RouteKind::Page, page("jobs.html"));
    route(server, "/dashboard/job", RouteKind::Page, page("job.html"));
    route(server, "/dashboard/workers", RouteKind::Page, page("workers.html"));
    route(server, "/dashboard/app.js", RouteKind::Api, page("app.js"));
    route(server, "/dashboard/style.css", RouteKind::Api, page("style.css"));
    route(server, "/dashboard/logout", RouteKind::Session,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              m_sessions.close(cookieValue(request, kSessionCookie));
              response.addHeader("Set-Cookie", std::string(kSessionCookie) +
                                                   "=; Path=/; HttpOnly; SameSite=Strict; "
                                                   "Max-Age=0");
              jsonAnswer(response, "{}");
          });

    route(server, "/api/session", RouteKind::Api,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              const bool operatorRole = identify(request).role == DashboardRole::Operator;
              jsonAnswer(response, std::string("{\"role\":\"") +
                                       (operatorRole ? "operator" : "viewer") + "\"}");
          });
    route(server, "/api/jobs", RouteKind::Api,
          [this](const farm::HttpRequest&, farm::HttpResponse& response) { jobsJson(response); });
    route(server, "/api/job", RouteKind::Api,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              jobJson(request, response);
          });
    route(server, "/api/job/preview.png", RouteKind::Api,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              previewPng(request, response);
          });
    route(
        server, "/api/workers", RouteKind::Api,
        [this](const farm::HttpRequest&, farm::HttpResponse& response) { workersJson(response); });
    for (const char* action : {"pause", "resume", "retry", "cancel", "delete", "priority"})
        route(server, std::string("/api/job/") + action, RouteKind::Action,
              [this, action = std::string(action)](const farm::HttpRequest& request,
                                                   farm::HttpResponse& response) {
                  jobAction(request, response, action);
              });
    route(server, "/api/worker/drain", RouteKind::Action,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              workerAction(request, response, true);
          });
    route(server, "/api/worker/undrain", RouteKind::Action,
          [this](const farm::HttpRequest& request, farm::HttpResponse& response) {
              workerAction(request, response, false);
          });
}

// ---- the JSON API ------------------------------------------------------------------------------

void Dashboard::jobsJson(farm::HttpResponse& response) {
    v1::ListJobsResponse list;
    std::vector<v1::JobStatus> jobs = m_coordinator.listJobs(0);
    record(jobs);
    for (auto& job : jobs) *list.add_jobs() = std::move(job);
    jsonAnswer(response, farm::toJson(list));
}

void Dashboard::jobJson(const farm::HttpRequest& request, farm::HttpResponse& response) {
    const uint64_t jobId = numberParam(request, "id");
    const uint64_t after = request.hasParam("after") ? numberParam(request, "after") : 0;
    std::vector<v1::JobStatus> jobs = m_coordinator.listJobs(jobId);
    record(jobs);
    std::string history;
    for (const EstimatePoint& point : this->history(jobId))
        history += std::string(history.empty() ? "" : ",") +
                   "{\"passes\":" + std::to_string(point.passes) +
                   ",\"relative_rmse\":" + number(point.relativeRmse) + "}";
    jsonAnswer(response, "{\"job\":" + farm::toJson(jobs.at(0)) + ",\"history\":[" + history +
                             "],\"log\":" + farm::toJson(m_coordinator.jobLog(jobId, after)) + "}");
}

void Dashboard::previewPng(const farm::HttpRequest& request, farm::HttpResponse& response) {
    const uint64_t jobId = numberParam(request, "id");
    float exposure = 0;
    if (request.hasParam("exposure")) {
        const std::string text = request.param("exposure");
        const auto result = std::from_chars(text.data(), text.data() + text.size(), exposure);
        if (result.ec != std::errc() || result.ptr != text.data() + text.size() ||
            !(std::abs(exposure) <= kMaxPngExposureStops))
            throw FarmError(
                FarmError::Kind::InvalidArgument,
                absl::StrFormat("the parameter exposure must be a number from -%g to %g",
                                kMaxPngExposureStops, kMaxPngExposureStops));
    }
    // As GetImage does for `alphorn fetch --preview`: the same PNG writer, the same bytes.
    Coordinator::ImageSnapshot snapshot = m_coordinator.snapshot(jobId, true);
    const Image image =
        resolveImage(snapshot.film, int(snapshot.status.width()), int(snapshot.status.height()));
    std::string bytes = encodePNG(image, exposure);
    response.status = 200;
    response.addHeader("X-Alphorn-Units-Done", std::to_string(snapshot.status.units_done()));
    response.setContent(std::move(bytes), "image/png");
}

void Dashboard::workersJson(farm::HttpResponse& response) {
    v1::ListWorkersResponse list;
    for (auto& worker : m_coordinator.listWorkers(true)) *list.add_workers() = std::move(worker);
    std::string held;
    for (const auto& [workerId, units] : m_coordinator.heldUnits()) {
        std::string unitsJson;
        for (const Coordinator::HeldUnit& unit : units)
            unitsJson += std::string(unitsJson.empty() ? "" : ",") +
                         "{\"job_id\":" + std::to_string(unit.jobId) +
                         ",\"unit_index\":" + std::to_string(unit.unitIndex) + "}";
        held += std::string(held.empty() ? "" : ",") + "\"" + std::to_string(workerId) + "\":[" +
                unitsJson + "]";
    }
    std::string json = farm::toJson(list);
    json.pop_back();  // the closing brace of the list's object
    jsonAnswer(response, json + ",\"held_units\":{" + held + "}}");
}

void Dashboard::jobAction(const farm::HttpRequest& request, farm::HttpResponse& response,
                          const std::string& action) {
    const uint64_t jobId = numberParam(request, "id");
    const std::string requestId =
        action == "delete" || action == "retry" ? requestIdParam(request) : std::string();
    if (action == "delete") {
        // The page asks before it sends this; a running job is cancelled, then deleted.
        jsonAnswer(response, farm::toJson(m_coordinator.deleteJob(jobId, true, requestId)));
        logInfo("dashboard.action",
                {field("action", action), field("job", jobId), field("request", requestId)});
        return;
    }
    v1::JobStatus status;
    if (action == "pause") {
        status = m_coordinator.setPaused(jobId, true);
    } else if (action == "resume") {
        status = m_coordinator.setPaused(jobId, false);
    } else if (action == "retry") {
        status = m_coordinator.retry(jobId, requestId);
    } else if (action == "cancel") {
        status = m_coordinator.cancel(jobId);
    } else {
        const std::string text = request.param("priority");
        int32_t priority = 0;
        const auto result = std::from_chars(text.data(), text.data() + text.size(), priority);
        if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size())
            throw FarmError(FarmError::Kind::InvalidArgument,
                            "the parameter priority must be a whole number");
        status = m_coordinator.setPriority(jobId, priority);
    }
    logInfo("dashboard.action",
            {field("action", action), field("job", jobId), field("request", requestId)});
    jsonAnswer(response, "{\"job\":" + farm::toJson(status) + "}");
}

void Dashboard::workerAction(const farm::HttpRequest& request, farm::HttpResponse& response,
                             bool draining) {
    const uint64_t workerId = numberParam(request, "id");
    const v1::WorkerInfo worker = m_coordinator.setWorkerDraining(workerId, draining);
    logInfo("dashboard.action",
            {field("action", draining ? "drain" : "undrain"), field("worker", workerId)});
    jsonAnswer(response, "{\"worker\":" + farm::toJson(worker) + "}");
}

// ---- the estimate history ----------------------------------------------------------------------

void Dashboard::record(const std::vector<v1::JobStatus>& statuses) {
    std::lock_guard lock(m_historyMutex);
    for (const v1::JobStatus& status : statuses) {
        if (!status.has_error_estimate() || status.error_estimate_passes() == 0) continue;
        std::vector<EstimatePoint>& points = m_history[status.job_id()];
        const EstimatePoint point{status.error_estimate_passes(), status.error_estimate()};
        auto at = std::lower_bound(
            points.begin(), points.end(), point,
            [](const EstimatePoint& a, const EstimatePoint& b) { return a.passes < b.passes; });
        if (at != points.end() && at->passes == point.passes) {
            // Before a job without a target ends, an estimate may count units of later passes;
            // the latest one at these passes is the better.
            at->relativeRmse = point.relativeRmse;
        } else if (points.size() < kMaxHistoryPoints) {
            points.insert(at, point);
        }
    }
}

std::vector<Dashboard::EstimatePoint> Dashboard::history(uint64_t jobId) const {
    std::lock_guard lock(m_historyMutex);
    auto it = m_history.find(jobId);
    return it == m_history.end() ? std::vector<EstimatePoint>() : it->second;
}

void Dashboard::start() {
    if (m_sampling.joinable()) return;
    m_stopping = false;
    m_sampling = std::thread([this] { samplingLoop(); });
}

void Dashboard::stop() {
    {
        std::lock_guard lock(m_samplingMutex);
        m_stopping = true;
    }
    m_samplingWake.notify_all();
    if (m_sampling.joinable()) m_sampling.join();
}

void Dashboard::samplingLoop() {
    std::unique_lock lock(m_samplingMutex);
    while (!m_stopping) {
        lock.unlock();
        try {
            const std::vector<v1::JobStatus> jobs = m_coordinator.listJobs(0);
            record(jobs);
            // Jobs removed (deleted or past their keep time) take their history with them.
            std::set<uint64_t> present;
            for (const v1::JobStatus& job : jobs) present.insert(job.job_id());
            std::lock_guard historyLock(m_historyMutex);
            std::erase_if(m_history,
                          [&](const auto& entry) { return !present.count(entry.first); });
        } catch (const std::exception& e) {
            logWarning("dashboard.sampling_failed", {field("error", e.what())});
        }
        lock.lock();
        m_samplingWake.wait_for(lock, std::chrono::duration<double>(m_options.samplingSeconds),
                                [this] { return m_stopping; });
    }
}

}  // namespace alphorn::coordinator
