#!/usr/bin/python3
"""The coordinator's web dashboard in a real browser: headless Chromium driven by Selenium
(Debian's chromium, chromium-driver and python3-selenium) against a real coordinator started with
--http-listen --dashboard on loopback and two real workers rendering a job.

It checks that a request without a token is refused (401, also when /metrics is open to anyone),
that a wrong token does not log in, that the client token does, that the jobs page lists the
job, that the job page's preview image changes while the job runs (the PNG bytes at two moments
differ, and the page loads a new one), that pause, priority and resume act (the page and the API
show it), that cancel, retry and delete act on a second job (retry and delete each sending a request
id, which makes a repeated request act once), that the convergence chart draws the estimates, that the workers page drains and
undrains a worker, that an action sent with the session cookie but without the dashboard's
header is refused (403: no cross-site forgery), and that the viewer token sees the pages but
cannot act (403, buttons disabled).

With --screenshot PATH it also saves the job page once the job is done (docs/dashboard.png is made
so, with a larger scene: see docs/dashboard.md).
"""
import argparse
import json
import os
import re
import secrets
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.common.exceptions import (NoSuchElementException, StaleElementReferenceException,
                                        WebDriverException)
from selenium.webdriver.common.by import By

WAIT_SECONDS = 20


def fail(message):
    raise AssertionError(message)


def wait_for(what, condition, timeout=WAIT_SECONDS, interval=0.05):
    """Polls `condition` until it returns something true; fails naming `what` on timeout. An
    element not there yet (a page loading), or gone (the pages rebuild their tables every
    second), counts as not yet."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            value = condition()
        except (NoSuchElementException, StaleElementReferenceException):
            value = None
        if value:
            return value
        if time.monotonic() > deadline:
            fail(f"timed out waiting until {what}")
        time.sleep(interval)


class Farm:
    """A coordinator with the dashboard and two workers in a private temporary directory."""

    def __init__(self, args):
        self.args = args
        self.work = tempfile.mkdtemp(prefix="alphorn-dashboard-test-")
        self.processes = []
        self.tokens = {}
        for role in ("client", "worker", "viewer"):
            path = os.path.join(self.work, role + ".token")
            with open(path, "w") as file:
                file.write(secrets.token_hex(32) + "\n")
            os.chmod(path, 0o600)
            self.tokens[role] = open(path).read().strip()

    def path(self, name):
        return os.path.join(self.work, name)

    def spawn(self, name, command, env=None):
        log = open(self.path(name + ".log"), "w")
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                   env=dict(os.environ, **(env or {})))
        self.processes.append(process)
        return process

    def read_port(self, name, process):
        def port():
            if process.poll() is not None:
                fail(f"{name} exited at start: {open(self.path(name + '.log')).read()}")
            try:
                return int(open(self.path(name + ".port")).read())
            except (OSError, ValueError):
                return None
        return wait_for(f"{name} listens", port)

    def start(self, unit_delay_ms):
        coordinator = self.spawn("coordinator", [
            self.args.coordinator, "--listen", "127.0.0.1:0", "--state-dir", self.path("state"),
            "--client-token-file", self.path("client.token"),
            "--worker-token-file", self.path("worker.token"),
            "--port-file", self.path("coordinator.port"),
            "--http-listen", "127.0.0.1:0", "--http-port-file", self.path("http.port"),
            "--http-anonymous-metrics", "--dashboard",
            "--dashboard-viewer-token-file", self.path("viewer.token")])
        self.grpc = f"127.0.0.1:{self.read_port('coordinator', coordinator)}"
        self.http = self.read_port("http", coordinator)
        self.url = f"http://127.0.0.1:{self.http}"
        for name in ("a", "b"):
            # Each unit takes a while, so the job is seen running for a few seconds.
            self.spawn("worker-" + name, [
                self.args.worker, "--coordinator", self.grpc,
                "--token-file", self.path("worker.token"), "--cache-dir", self.path("cache-" + name),
                "--threads", "1", "--name", name],
                env={"ALPHORN_TEST_UNIT_DELAY_MS": str(unit_delay_ms)})

    def submit(self, scene, passes, name):
        output = subprocess.run(
            [self.args.alphorn, "submit", scene, "--passes", str(passes), "--tile", "256",
             "--passes-per-unit", "1", "--name", name],
            env=dict(os.environ, ALPHORN_COORDINATOR=self.grpc,
                     ALPHORN_TOKEN_FILE=self.path("client.token")),
            check=True, capture_output=True, text=True).stdout
        return output.strip().splitlines()[-1]

    def request(self, path, token=None, method="GET", cookie=None, headers=None):
        """(status, body bytes) of a request to the coordinator's HTTP server."""
        request = urllib.request.Request(self.url + path, method=method,
                                         data=b"" if method == "POST" else None)
        if token:
            request.add_header("Authorization", "Bearer " + token)
        if cookie:
            request.add_header("Cookie", cookie)
        for name, value in (headers or {}).items():
            request.add_header(name, value)
        try:
            with urllib.request.urlopen(request, timeout=10) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as error:
            return error.code, error.read()

    def job(self, job_id):
        status, body = self.request(f"/api/job?id={job_id}", self.tokens["client"])
        if status != 200:
            fail(f"/api/job answered {status}: {body!r}")
        return json.loads(body)["job"]

    def stop(self, keep):
        for process in self.processes:
            process.kill()
        for process in self.processes:
            process.wait()
        if keep:
            print(f"logs in {self.work}")
        else:
            shutil.rmtree(self.work, ignore_errors=True)


def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     "--window-size=1280,1000", "--disable-extensions", "--no-first-run"):
        options.add_argument(argument)
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)


def log_in(driver, farm, token):
    """Fills in and sends the login form, and waits until the browser has left that page."""
    driver.get(farm.url + "/dashboard/login")
    field = driver.find_element(By.ID, "token")
    field.clear()
    field.send_keys(token)
    form_page = driver.find_element(By.TAG_NAME, "html")
    driver.find_element(By.ID, "login").click()

    def left():
        try:
            form_page.tag_name
            return False
        except StaleElementReferenceException:
            return True
        except WebDriverException as error:
            # Asked while the next page replaces it, Chromium may answer that the element's node
            # "does not belong to the document" instead of calling it stale: the page was left.
            if "does not belong to the document" in str(error):
                return True
            raise
    wait_for("the login form is sent", left)


def ok(message):
    print("ok  ", message, flush=True)


def session_cookie(driver):
    cookie = driver.get_cookie("alphorn_session")
    return f"alphorn_session={cookie['value']}" if cookie else None


def run(args):
    farm = Farm(args)
    driver = None
    passed = False
    try:
        farm.start(args.unit_delay_ms)
        client, viewer = farm.tokens["client"], farm.tokens["viewer"]

        # ---- nothing without a token; /metrics may be open, the dashboard never.
        for path in ("/api/jobs", "/api/workers", "/dashboard/", "/api/job/preview.png?id=1"):
            status, _ = farm.request(path)
            if status != 401:
                fail(f"{path} without a token answered {status}, not 401")
        status, _ = farm.request("/api/jobs", farm.tokens["worker"])
        if status != 401:
            fail(f"/api/jobs with the worker token answered {status}, not 401")
        if farm.request("/metrics")[0] != 200:
            fail("--http-anonymous-metrics did not open /metrics")
        ok("requests without a token (or with the worker token) are refused: 401; "
           "--http-anonymous-metrics opens /metrics only")

        driver = browser()
        driver.set_script_timeout(10)
        # ---- a wrong token does not log in.
        log_in(driver, farm, "not-the-token")
        problem = wait_for("the login form answers",
                           lambda: driver.find_element(By.ID, "problem").text)
        if "not valid" not in problem or session_cookie(driver):
            fail(f"a wrong token logged in (problem text {problem!r})")
        ok("a wrong token is refused at the login form")

        # ---- the client token logs in; the jobs page lists the job, submitted now so that it
        # is still running when the job page is open, however long the browser took to start.
        log_in(driver, farm, client)
        wait_for("the jobs page shows", lambda: driver.find_elements(By.ID, "jobs"))
        job_id = farm.submit(args.scene, args.passes, "dashboard-test")
        wait_for("the jobs page lists the job",
                 lambda: driver.find_elements(By.CSS_SELECTOR, f'#jobs tr[data-job="{job_id}"]'))
        row = driver.find_element(By.CSS_SELECTOR, f'#jobs tr[data-job="{job_id}"]')
        if "dashboard-test" not in row.text:
            fail(f"the job's row does not show its name: {row.text!r}")
        cookie = session_cookie(driver)
        if not cookie:
            fail("logging in set no session cookie")
        ok(f"the client token logs in; the jobs page lists job {job_id}: {row.text!r}")

        # ---- the job page: the preview changes while the job runs.
        row.find_element(By.TAG_NAME, "a").click()
        wait_for("the job page loads", lambda: driver.find_elements(By.CSS_SELECTOR, "#facts dd"))

        def preview_loaded():
            return driver.execute_script(
                "const i = document.getElementById('preview');"
                "return i.complete && i.naturalWidth > 0 ? i.src : null;")
        first_src = wait_for("the preview image loads", preview_loaded)
        first_units = farm.job(job_id)["units_done"]
        status, first_png = farm.request(f"/api/job/preview.png?id={job_id}", cookie=cookie)
        if status != 200 or not first_png.startswith(b"\x89PNG"):
            fail(f"the preview is not a PNG (status {status})")
        wait_for("more units are merged", lambda: farm.job(job_id)["units_done"] >= first_units + 2)
        second_png = farm.request(f"/api/job/preview.png?id={job_id}", cookie=cookie)[1]
        if second_png == first_png:
            fail("the preview PNG did not change while units merged")
        wait_for("the page loads a newer preview",
                 lambda: (preview_loaded() or first_src) != first_src)
        if farm.job(job_id)["state"] != "JOB_STATE_RUNNING":
            fail("the job ended before the preview could be watched; make it longer")
        ok("the preview PNG changes while the job runs, and the page reloads it")

        # ---- an action with the cookie but without the dashboard's header: refused.
        status, body = farm.request(f"/api/job/pause?id={job_id}", method="POST", cookie=cookie)
        if status != 403 or farm.job(job_id)["paused"]:
            fail(f"a cookie-only POST (as a forged cross-site form sends it) answered {status}")
        ok("an action with the session cookie but without X-Alphorn-Dashboard is refused: 403")

        # ---- pause from the page.
        driver.find_element(By.ID, "pause").click()
        wait_for("the page shows the job paused",
                 lambda: driver.find_element(By.CSS_SELECTOR, "#facts dd").text == "paused")
        if not farm.job(job_id)["paused"]:
            fail("the page shows paused but the coordinator does not")
        ok("Pause: the page and the API show the job paused")

        # ---- priority from the page.
        priority = driver.find_element(By.ID, "priority")
        priority.clear()
        priority.send_keys("7")
        driver.find_element(By.ID, "set-priority").click()
        wait_for("the coordinator has priority 7",
                 lambda: farm.job(job_id)["settings"]["priority"] == 7)
        ok("Set priority: the coordinator has priority 7")

        # ---- resume; the job finishes and the chart shows its estimates.
        driver.find_element(By.ID, "resume").click()
        wait_for("the job is done", lambda: farm.job(job_id)["state"] == "JOB_STATE_DONE",
                 timeout=args.job_seconds)
        wait_for("the page shows done",
                 lambda: driver.find_element(By.CSS_SELECTOR, "#facts dd").text == "done")
        points = wait_for("the chart draws the estimates",
                          lambda: driver.find_elements(By.CSS_SELECTOR, "#chart circle.point"))
        ticks = driver.find_elements(By.CSS_SELECTOR, "#chart text")
        if not any(t.text == "passes (log scale)" for t in ticks):
            fail("the chart has no axis label")
        log_rows = driver.find_elements(By.CSS_SELECTOR, "#log tbody tr")
        kinds = {row.find_elements(By.TAG_NAME, "td")[2].text for row in log_rows}
        for kind in ("submitted", "paused", "priority changed", "resumed", "finished"):
            if kind not in kinds:
                fail(f"the event log shows no '{kind}' event (it shows {sorted(kinds)})")
        ok(f"Resume: the job finished; the chart has {len(points)} estimates; the log shows "
           "submitted, paused, priority changed, resumed, finished")

        if args.screenshot:
            # Reload so that the preview holds every unit.
            driver.get(farm.url + f"/dashboard/job?id={job_id}")
            wait_for("the final preview loads", preview_loaded)
            wait_for("the chart draws",
                     lambda: driver.find_elements(By.CSS_SELECTOR, "#chart circle.point"))
            height = driver.execute_script("return document.body.scrollHeight")
            driver.set_window_size(1280, min(max(height, 700), 1400))
            time.sleep(0.3)
            driver.save_screenshot(args.screenshot)
            ok(f"screenshot saved: {args.screenshot}")

        # ---- a second job: Cancel, Retry and Delete from its page (each asks first).
        second_id = farm.submit(args.scene, args.passes, "dashboard-test-2")
        driver.get(farm.url + f"/dashboard/job?id={second_id}")

        def shown_state():
            return driver.find_element(By.CSS_SELECTOR, "#facts dd").text

        def confirmed_click(button):
            wait_for(f"{button} is enabled",
                     lambda: driver.find_element(By.ID, button).is_enabled())
            driver.find_element(By.ID, button).click()
            driver.switch_to.alert.accept()
        wait_for("the second job's page shows it running", lambda: shown_state() == "running")
        confirmed_click("cancel")
        wait_for("the page shows the job cancelled", lambda: shown_state() == "cancelled")
        if farm.job(second_id)["state"] != "JOB_STATE_CANCELLED":
            fail("the page shows cancelled but the coordinator does not")
        driver.find_element(By.ID, "retry").click()
        wait_for("the page shows the retried job running", lambda: shown_state() == "running")
        confirmed_click("delete")
        wait_for("Delete goes back to the jobs page",
                 lambda: driver.current_url.endswith("/dashboard/"))
        status, _ = farm.request(f"/api/job?id={second_id}", client)
        if status != 404:
            fail(f"the deleted job is still there (/api/job answered {status})")
        ok("Cancel, Retry and Delete act on a second job (404 once deleted)")
        log = open(farm.path("coordinator.log")).read()
        for action in ("retry", "delete"):
            if not re.search(rf'event=dashboard\.action action={action} job={second_id} '
                             r'request="?[0-9a-f]{32}\b', log):
                fail(f"the page's {action} sent no request id (no dashboard.action line of "
                     f"coordinator.log names one)")
        ok("Retry and Delete send a request id of 32 hex digits")

        # ---- the workers page: drain and undrain worker a.
        driver.get(farm.url + "/dashboard/workers")

        def worker_row(name):
            for row in driver.find_elements(By.CSS_SELECTOR, "#workers tbody tr"):
                cells = row.find_elements(By.TAG_NAME, "td")
                if len(cells) > 2 and cells[1].text == name:
                    return row
            return None
        wait_for("the workers page lists both workers", lambda: worker_row("a") and worker_row("b"))

        def click_in_row(name, selector):
            worker_row(name).find_element(By.CSS_SELECTOR, selector).click()
            return True

        def state_of(name):
            return worker_row(name).find_elements(By.TAG_NAME, "td")[2].text
        wait_for("worker a's Drain is clicked", lambda: click_in_row("a", "button.drain"))
        wait_for("worker a shows draining", lambda: state_of("a") == "draining")
        wait_for("worker a's Undrain is clicked", lambda: click_in_row("a", "button.undrain"))
        wait_for("worker a shows alive again", lambda: state_of("a") == "alive")
        ok("the workers page drains and undrains a worker")

        # ---- the viewer token sees but cannot act.
        driver.delete_all_cookies()
        log_in(driver, farm, viewer)
        wait_for("the viewer sees the job",
                 lambda: driver.find_elements(By.CSS_SELECTOR, f'#jobs tr[data-job="{job_id}"]'))
        viewer_cookie = session_cookie(driver)
        driver.get(farm.url + f"/dashboard/job?id={job_id}")
        wait_for("the viewer's job page loads",
                 lambda: driver.find_element(By.ID, "role").text.startswith("viewer"))
        wait_for("the viewer's buttons are disabled",
                 lambda: not driver.find_element(By.ID, "delete").is_enabled())
        for path in (f"/api/job/priority?id={job_id}&priority=1", f"/api/job/delete?id={job_id}"):
            status, _ = farm.request(path, method="POST", cookie=viewer_cookie,
                                     headers={"X-Alphorn-Dashboard": "1"})
            if status != 403:
                fail(f"the viewer's session POST {path} answered {status}, not 403")
            status, _ = farm.request(path, viewer, method="POST")
            if status != 403:
                fail(f"the viewer token's POST {path} answered {status}, not 403")
        if farm.job(job_id)["settings"]["priority"] != 7:
            fail("a viewer changed the priority")
        ok("the viewer sees the pages; its actions are refused (403) and its buttons disabled")
        passed = True
    finally:
        if driver:
            driver.quit()
        farm.stop(keep=not passed or args.keep)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coordinator", required=True)
    parser.add_argument("--worker", required=True)
    parser.add_argument("--alphorn", required=True)
    parser.add_argument("--scene", required=True)
    parser.add_argument("--passes", type=int, default=64)
    parser.add_argument("--unit-delay-ms", type=int, default=150)
    parser.add_argument("--job-seconds", type=float, default=60,
                        help="how long the job may take once resumed")
    parser.add_argument("--screenshot", help="save the job page here (PNG)")
    parser.add_argument("--keep", action="store_true", help="keep the logs")
    args = parser.parse_args()
    started = time.monotonic()
    try:
        run(args)
    except AssertionError as error:
        print(f"FAIL: {error}", file=sys.stderr)
        return 1
    print(f"passed in {time.monotonic() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
