"""The desk's page in a real browser: headless Chromium (Debian's chromium and chromium-driver)
driven over WebDriver (selenium) against the desk on the served pod — a machine created and a
tolerance set through the page's forms, a circle pair run from it with screenshots of the live
trace taken and checked for the trace's colour growing, the results and the report opened, the
report printed to PDF and its first page checked as an image.

$BALLPOD_DESK_SCREENS names a folder to keep the screenshots in (the book's tutorial takes
them from there: `docs/src/images/desk`)."""
import io
import os
import pathlib
import shutil
import subprocess
import time
import base64

import pytest

from test_desk import Desk, decision

pytestmark = pytest.mark.desk

CHROMIUM, DRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
TRACE_BLUE = (0x1F, 0x4F, 0xD1)  # the live trace's and the CCW plot's colour (page.html, report/svg.rs)


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              "--window-size=1280,1800"]:
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(DRIVER), options=opts)


def pixels_near(png, rgb, tol=60):
    """How many pixels of a PNG are within `tol` of colour `rgb` (each channel)."""
    from PIL import Image
    img = Image.open(io.BytesIO(png)).convert("RGB")
    px = img.tobytes()
    return sum(1 for k in range(0, len(px), 3) if all(abs(px[k + c] - rgb[c]) <= tol for c in range(3)))


def run_from_page(b, test, seconds=120):
    """Presses Run and waits until the page says test number `test` is done."""
    from selenium.webdriver.common.by import By
    b.find_element(By.ID, "c-run").click()
    t0 = time.time()
    while not (b.find_element(By.ID, "live-run").text == str(test)
               and b.find_element(By.ID, "live-step").text.startswith("done")):
        assert time.time() - t0 < seconds, (b.find_element(By.ID, "live-step").text, b.find_element(By.ID, "error").text)
        time.sleep(0.2)


def test_the_page_in_a_browser_runs_a_circle_pair_and_prints_its_report(pod, tmp_path):
    if not (os.path.exists(CHROMIUM) and os.path.exists(DRIVER)):
        # .ci/run installs them and sets $BALLPOD_REQUIRE_CHROMIUM: CI fails rather than skips
        assert not os.environ.get("BALLPOD_REQUIRE_CHROMIUM"), "Debian's chromium and chromium-driver are missing"
        pytest.skip("Debian's chromium and chromium-driver are not installed")
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait
    keep = os.environ.get("BALLPOD_DESK_SCREENS")
    shots = pathlib.Path(keep) if keep else tmp_path
    shots.mkdir(parents=True, exist_ok=True)
    desk = Desk(tmp_path, pod)
    b = browser()
    try:
        wait = WebDriverWait(b, 60)
        b.get(desk.url)
        wait.until(lambda b: b.find_element(By.ID, "pod").text.startswith("BALLPOD,"))
        # a machine, through the form
        b.find_element(By.CSS_SELECTOR, "#machines details summary").click()
        for field, value in [("name", "DMU 50 #3"), ("builder", "DMG MORI"), ("model", "DMU 50"),
                             ("serial", "12345"), ("kinematics", "table-table B/C"), ("axes", "X Y Z B C")]:
            b.find_element(By.ID, f"m-{field}").send_keys(value)
        b.find_element(By.ID, "m-add").click()
        wait.until(lambda b: Select(b.find_element(By.ID, "machine")).first_selected_option.text == "DMU 50 #3")
        # a tolerance on G_ccw that the machine's G (≈ 22 µm) breaks by more than U
        b.find_elements(By.CSS_SELECTOR, "#machines details summary")[1].click()
        b.find_element(By.ID, "t-figure").send_keys("G_ccw")
        b.find_element(By.ID, "t-upper").send_keys("15")
        b.find_element(By.ID, "t-set").click()
        wait.until(lambda b: "G_ccw" in b.find_element(By.ID, "tolerances").text)
        b.save_screenshot(str(shots / "desk-machine.png"))

        # the run: the live trace grows on screen
        b.find_element(By.ID, "c-operator").send_keys("A. Tester")
        b.find_element(By.ID, "c-run").click()
        blue = []
        t0 = time.time()
        while not b.find_element(By.ID, "live-step").text.startswith("done"):
            assert time.time() - t0 < 120, b.find_element(By.ID, "live-step").text
            moving = "run 1 of 2 (CIRCLE CCW): the machine moves"
            # the page sets step, count and trace in one poll, but each read here is a separate
            # round trip: a look counts only if the step still reads run 1 after it (the page
            # may have moved on to run 2, whose count starts again, between two reads), and once
            # a sample has come (the run's first poll shows none, and no trace)
            if b.find_element(By.ID, "live-step").text == moving:
                png = b.find_element(By.ID, "trace").screenshot_as_png
                n = int(b.find_element(By.ID, "live-samples").text)
                if n > 0 and b.find_element(By.ID, "live-step").text == moving:
                    blue.append((n, pixels_near(png, TRACE_BLUE)))
                    if len(blue) == 3:
                        (shots / "desk-live.png").write_bytes(b.get_screenshot_as_png())
            time.sleep(0.2)
        assert len(blue) >= 3, blue
        samples = [n for n, _ in blue]
        assert samples == sorted(samples) and samples[-1] > samples[0], blue
        assert blue[-1][1] > blue[0][1], blue  # more of the trace drawn, screenshot by screenshot

        # the results: the decision shown per the rule, the figures equal the desk's API
        wait.until(lambda b: "G_ccw" in b.find_element(By.ID, "r-figures").text)
        run_id = desk.ok("/api/runs")[-1]["id"]
        view = desk.ok(f"/api/runs/{run_id}")
        g = next(f for f in view["figures"] if f["name"] == "G_ccw")
        row = b.find_element(By.CSS_SELECTOR, '#r-figures tr[data-name="G_ccw"]')
        want = decision(g["value"], g["expanded_u"], None, 15)
        assert row.get_attribute("class") == want
        assert row.find_elements(By.TAG_NAME, "td")[1].text == f'{g["value"]:.4f}'
        assert "replay equals the pod's results" in b.find_element(By.ID, "r-head").text
        b.save_screenshot(str(shots / "desk-results.png"))

        # the report, and its PDF's first page as an image
        b.find_element(By.CSS_SELECTOR, "#h-runs a.report").click()
        wait.until(lambda b: b.find_elements(By.ID, "figures"))
        cell = b.find_element(By.CSS_SELECTOR, '#figures tr[data-name="G_ccw"] td.value')
        assert cell.text == f'{g["value"]:.4f}'
        b.save_screenshot(str(shots / "desk-report.png"))
        pdf = base64.b64decode(b.print_page())
        assert pdf.startswith(b"%PDF")
        (tmp_path / "report.pdf").write_bytes(pdf)
        subprocess.run(["pdftoppm", "-png", "-r", "100", "-f", "1", "-l", "1", str(tmp_path / "report.pdf"),
                        str(tmp_path / "page")], check=True)
        page = next(tmp_path.glob("page*.png")).read_bytes()
        # the first page carries the title and the polar plot: its CCW trace in blue
        assert pixels_near(page, TRACE_BLUE) > 100
        if keep:
            shutil.copy(next(tmp_path.glob("page*.png")), shots / "desk-report-pdf-page1.png")

        # two more circle pairs from the page: the trend chart shows three points
        b.get(desk.url)
        wait.until(lambda b: Select(b.find_element(By.ID, "machine")).first_selected_option.text == "DMU 50 #3")
        b.find_element(By.ID, "c-operator").send_keys("A. Tester")
        for test in (2, 3):
            run_from_page(b, test)
        b.find_element(By.ID, "h-figure").send_keys("G_ccw")
        b.find_element(By.ID, "h-show").click()
        img = wait.until(lambda b: b.find_elements(By.CSS_SELECTOR, "#h-trend img"))[0]
        wait.until(lambda b: b.execute_script("return arguments[0].complete && arguments[0].naturalWidth", img))
        status, svg = desk.call(img.get_attribute("src").split("/", 3)[3])
        assert status == 200 and svg.count('class="point"') == 3

        # the seed 002 procedure from the page, its set-up typed into the form
        from podlib import TABLE_4_3
        Select(b.find_element(By.ID, "c-test")).select_by_value("seed002")
        for name, value in TABLE_4_3.items():
            field = b.find_element(By.ID, f"s-{name}")
            field.clear()
            field.send_keys(str(value))
        run_from_page(b, 4, seconds=180)
        wait.until(lambda b: "dx_BT" in b.find_element(By.ID, "r-figures").text)
        assert "replay equals the pod's results" in b.find_element(By.ID, "r-head").text
        truth = pod["truth"]["machine"]["seed002"]
        row = b.find_element(By.CSS_SELECTOR, '#r-figures tr[data-name="alpha_XB"]')
        value = float(row.find_elements(By.TAG_NAME, "td")[1].text)
        assert abs(value - truth["alpha_xb_arcsec"]) <= 0.5, value
    finally:
        b.quit()
        desk.close()
