"""What a reader of the HTML report sees, checked in headless Chromium:
every <img> decoded (complete, natural width > 0), every <table> with at
least one body row, every section of `SECTIONS` present, and a screenshot
of the top of the page. Needs Debian's `chromium` and `chromium-driver` and
the `selenium` package (`make check-report` installs them when absent)."""

import shutil
from pathlib import Path


def _driver():
    # optional dependency: only the browser check needs selenium
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    if binary:
        opts.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu",
                "--disable-dev-shm-usage", "--window-size=1280,1600"):  # fmt: skip
        opts.add_argument(arg)
    driver_path = shutil.which("chromedriver")
    service = Service(executable_path=driver_path) if driver_path else Service()
    return webdriver.Chrome(options=opts, service=service)


def check_in_browser(report: Path, screenshot: Path) -> list[str]:
    """Open `report` (an index.html) in headless Chromium after the page has
    loaded, save a screenshot of its top to `screenshot` and return one
    failure message per image that did not load, table without rows or
    section missing (empty: the page reads as built)."""
    from . import SECTIONS  # cycle: the package defines SECTIONS and imports this

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
        ids = set(
            driver.execute_script(
                "return Array.from(document.querySelectorAll('section'))"
                ".map(s => s.id)"
            )
        )
        failures = [f"image did not load: {alt!r}" for alt, ok, _ in imgs if not ok]
        failures += [f"table without rows: {cap!r}" for cap, n in tables if n == 0]
        failures += [
            f"section missing: {sid}" for sid, _, _ in SECTIONS if sid not in ids
        ]
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
