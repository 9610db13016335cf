"""Open the HTML report in headless Chromium and check what a reader sees.

Run:   python -m experiments.check_report [--report results/report/index.html]
           [--screenshot results/report/screenshot.png]

Needs Debian's `chromium` and `chromium-driver` and the `selenium` package
(`make check-report` installs them when absent). Checks, in the browser after
the page has loaded: every <img> decoded (complete, natural width > 0), every
<table> has at least one body row, every section of `bandopt.report.SECTIONS`
is present; then saves a screenshot of the top of the page. Exit status 1
with the list of failures when a check fails.
"""

import argparse
import shutil
import sys
from pathlib import Path


def _driver():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    if binary:
        opts.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu",
                "--disable-dev-shm-usage", "--window-size=1280,1600"):
        opts.add_argument(arg)
    driver_path = shutil.which("chromedriver")
    service = Service(executable_path=driver_path) if driver_path else Service()
    return webdriver.Chrome(options=opts, service=service)


def check(report: Path, screenshot: Path) -> list[str]:
    from bandopt.report import SECTIONS

    driver = _driver()
    try:
        driver.get(report.resolve().as_uri())
        driver.execute_script("return document.readyState")
        imgs = driver.execute_script(
            "return Array.from(document.images).map(i => "
            "[i.alt, i.complete && i.naturalWidth > 0, i.naturalWidth])"
        )
        tables = driver.execute_script(
            "return Array.from(document.querySelectorAll('table')).map(t => "
            "[t.caption ? t.caption.textContent : t.closest('section').id, "
            "t.querySelectorAll('tbody tr').length])"
        )
        ids = set(driver.execute_script(
            "return Array.from(document.querySelectorAll('section')).map(s => s.id)"
        ))
        failures = [f"image did not load: {alt!r}" for alt, ok, _ in imgs if not ok]
        failures += [f"table without rows: {cap!r}" for cap, n in tables if n == 0]
        failures += [f"section missing: {sid}" for sid, _, _ in SECTIONS
                     if sid not in ids]
        if not imgs:
            failures.append("no images in the report")
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(screenshot))
        print(
            f"{report}: {len(imgs)} images ({sum(ok for _, ok, _ in imgs)} loaded), "
            f"{len(tables)} tables (all with rows: "
            f"{all(n > 0 for _, n in tables)}), {len(ids)} sections; "
            f"screenshot {screenshot}"
        )
    finally:
        driver.quit()
    return failures


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--report", default="results/report/index.html", type=Path)
    p.add_argument("--screenshot", default="results/report/screenshot.png", type=Path)
    args = p.parse_args(argv)
    if not args.report.is_file():
        print(f"{args.report}: no report; run `make report` first.", file=sys.stderr)
        return 2
    failures = check(args.report, args.screenshot)
    for f in failures:
        print("FAIL:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
