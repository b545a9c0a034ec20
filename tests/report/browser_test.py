#!/usr/bin/python3
"""Opens a study's index.html in headless Chromium (Debian's chromium + chromium-driver, driven
by python3-selenium) from file:// with the network cut off, and fails on: a console error, a
broken image, a resource that is not a file inside the study folder, a verdict matrix that is
not the page's first table or whose cells link nowhere, a viewer whose key does not change the
displayed image (checked by its src and by the pixels), an exposure slider that does nothing.
Saves screenshots of the top of the page and of the first material's viewer.

    browser_test.py STUDY_DIR SCREENSHOT_DIR

Exit 0 pass, 1 fail, 77 skip (no chromium, chromedriver or selenium: CTest SKIP_RETURN_CODE).
"""

import os
import shutil
import socket
import sys
import time

SKIP = 77


def skip(why):
    print(f"SKIP: {why}")
    sys.exit(SKIP)


def find_binary(names):
    for n in names:
        p = shutil.which(n)
        if p:
            return p
    return None


def layout_problems(driver):
    """A page that holds many fits (docs/studies.md, "Report"): nothing wider than the window,
    and no verdict-matrix question squeezed to about one word per line."""
    out = []
    width = driver.execute_script("return [document.documentElement.scrollWidth, window.innerWidth]")
    if width[0] > width[1]:
        out.append(f"the page is {width[0]} px wide in a {width[1]} px window (horizontal overflow)")
    squeezed = driver.execute_script(
        "return Array.from(document.querySelectorAll('table.matrix td.question')).map(td => {"
        " const lh = parseFloat(getComputedStyle(td).lineHeight) || 16;"
        " const pad = parseFloat(getComputedStyle(td).paddingTop) + parseFloat(getComputedStyle(td).paddingBottom);"
        " const lines = Math.round((td.getBoundingClientRect().height - pad) / lh);"
        " const words = td.textContent.trim().split(/\\s+/).length;"
        " return [td.textContent.trim(), lines, words]; })"
        ".filter(([t, lines, words]) => words > 2 && words / lines < 2.5)")
    for text, lines, words in squeezed:
        out.append(f"matrix question '{text}' takes {lines} lines for {words} words")
    return out


def make_driver(chromium, driver_bin, width, height):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", f"--window-size={width},{height}",
              "--hide-scrollbars", "--force-device-scale-factor=1",
              # No network at all: any http(s) request fails, so a CDN dependency would show
              # as a console error or a broken resource below.
              "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE localhost",
              "--disable-background-networking", "--no-first-run"]:
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_bin), options=opts)


def layout_main(index, shot):
    """browser_test.py --layout INDEX.html SCREENSHOT.png: the many-fits layout checks only, at
    1400 px (the synthetic 10-fit study of many_fits_test.py)."""
    chromium = find_binary(["chromium", "chromium-browser"])
    driver_bin = find_binary(["chromedriver"])
    if chromium is None or driver_bin is None:
        skip("chromium or chromedriver not installed (Debian: chromium chromium-driver)")
    try:
        import selenium  # noqa: F401
    except ImportError:
        skip("python3-selenium not installed (scripts/bootstrap.sh test installs it)")
    driver = make_driver(chromium, driver_bin, 1400, 1000)
    try:
        driver.get("file://" + os.path.abspath(index))
        failures = layout_problems(driver)
        n = driver.execute_script("return document.querySelectorAll('table.matrix td.question').length")
        if n == 0:
            failures.append("no verdict-matrix question on the page")
        os.makedirs(os.path.dirname(os.path.abspath(shot)), exist_ok=True)
        driver.save_screenshot(shot)
    finally:
        driver.quit()
    for f in failures:
        print("FAILED: " + f)
    if not failures:
        print(f"PASS: {n} matrix questions laid out at 1400 px without overflow ({shot})")
    return 1 if failures else 0


def main(argv):
    if len(argv) == 4 and argv[1] == "--layout":
        return layout_main(argv[2], argv[3])
    if len(argv) != 3:
        print("usage: browser_test.py STUDY_DIR SCREENSHOT_DIR", file=sys.stderr)
        return 2
    study_dir, shot_dir = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    index = os.path.join(study_dir, "report", "index.html")
    if not os.path.exists(index):
        print(f"FAILED: {index}: missing (the quick study's report was not made)")
        return 1
    chromium = find_binary(["chromium", "chromium-browser"])
    driver_bin = find_binary(["chromedriver"])
    if chromium is None or driver_bin is None:
        skip("chromium or chromedriver not installed (Debian: chromium chromium-driver; "
             "scripts/bootstrap.sh test installs them)")
    try:
        from selenium.webdriver.common.action_chains import ActionChains
        from selenium.webdriver.common.by import By
    except ImportError:
        skip("python3-selenium not installed (scripts/bootstrap.sh test installs it)")

    os.makedirs(shot_dir, exist_ok=True)
    failures = []
    # selenium reaches chromedriver at localhost:<port>; where 'localhost' does not resolve (no
    # /etc/hosts, as in a bare minbase chroot) it only says "Can not connect to the Service".
    try:
        socket.getaddrinfo("localhost", None)
    except OSError as e:
        print(f"FAILED: 'localhost' does not resolve ({e}): selenium cannot reach chromedriver "
              "(is /etc/hosts missing its '127.0.0.1 localhost' line?)")
        return 1
    driver = make_driver(chromium, driver_bin, 1280, 1000)
    try:
        t0 = time.time()
        driver.get("file://" + index)
        # Every image settles (loaded or failed) before the checks.
        for _ in range(100):
            if driver.execute_script(
                    "return Array.from(document.images).every(i => i.complete)"):
                break
            time.sleep(0.05)
        print(f"loaded {index} in {time.time() - t0:.2f} s")

        broken = driver.execute_script(
            "return Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0)"
            ".map(i => i.getAttribute('src'))")
        if broken:
            failures.append(f"{len(broken)} broken image(s): {broken[:5]}")
        n_images = driver.execute_script("return document.images.length")
        print(f"{n_images} images, {len(broken)} broken")

        resources = driver.execute_script(
            "return performance.getEntriesByType('resource').map(e => e.name)")
        foreign = [r for r in resources
                   if not r.startswith("file://" + study_dir + "/")]
        if foreign:
            failures.append(f"resources outside the study folder: {foreign[:5]}")

        first_table = driver.execute_script(
            "const t = document.querySelector('table'); return t ? t.className : null")
        if first_table != "findings":
            failures.append(f"the first table is not the findings' (class {first_table!r})")
        # The findings open the page, then the comparative answers (each question with its
        # sentences, folded), both before the matrix.
        answers_first = driver.execute_script(
            "const f = document.querySelector('#findings'), a = document.querySelector('#answers'),"
            " t = document.querySelector('table.matrix');"
            "const after = (x, y) => !!(x.compareDocumentPosition(y) & Node.DOCUMENT_POSITION_FOLLOWING);"
            "return !!f && !!a && !!t && after(f, a) && after(a, t)"
            " && a.querySelectorAll('details ul.answers li').length > 0")
        if not answers_first:
            failures.append("the page does not open with the findings, then the answers (folded)")
        before_fig = driver.execute_script(
            "const t = document.querySelector('table.matrix'),"
            " f = document.querySelector('section:not(#answers):not(#findings) figure');"
            "return !!t && !!f && !!(t.compareDocumentPosition(f) & Node.DOCUMENT_POSITION_FOLLOWING)")
        if not before_fig:
            failures.append("the verdict matrix does not come before the first evidence figure")
        failures += layout_problems(driver)
        dangling = driver.execute_script(
            "return Array.from(document.querySelectorAll('table.matrix a')).map(a => a.getAttribute('href'))"
            ".filter(h => !h.startsWith('#') || !document.getElementById(h.slice(1)))")
        cells = driver.execute_script("return document.querySelectorAll('table.matrix td a').length")
        if dangling or cells == 0:
            failures.append(f"verdict matrix links without a target: {dangling[:5]} ({cells} links)")
        dup_ids = driver.execute_script(
            "const n = {}; document.querySelectorAll('[id]').forEach(e => n[e.id] = (n[e.id] || 0) + 1);"
            "return Object.keys(n).filter(k => n[k] > 1)")
        if dup_ids:
            failures.append(f"ids used more than once (links land on the first): {dup_ids[:5]}")
        collapsed = driver.execute_script(
            "return Array.from(document.querySelectorAll('#details ~ details')).every(d => !d.open)")
        if not collapsed:
            failures.append("detail tables are not collapsed by default")

        driver.save_screenshot(os.path.join(shot_dir, "top.png"))

        viewer = driver.find_element(By.CSS_SELECTOR, ".viewer")
        # The material's heading and its viewer in the screenshot.
        driver.execute_script("arguments[0].closest('section').scrollIntoView({block: 'start'})",
                              viewer)
        visible_src = ("const g = Array.from(arguments[0].querySelectorAll('.lighting-group'))"
                       ".find(g => !g.classList.contains('hidden'));"
                       "const im = Array.from(g.querySelectorAll('.stack img'))"
                       ".filter(i => getComputedStyle(i).display !== 'none');"
                       "return im.map(i => i.getAttribute('src'));")
        stack = viewer.find_element(By.CSS_SELECTOR, ".lighting-group:not(.hidden) .stack")
        shown0 = driver.execute_script(visible_src, viewer)
        pixels0 = stack.screenshot_as_png
        ActionChains(driver).move_to_element(stack).click(stack).perform()
        ActionChains(driver).send_keys(" ").perform()
        time.sleep(0.1)
        shown1 = driver.execute_script(visible_src, viewer)
        pixels1 = stack.screenshot_as_png
        print(f"viewer: before the key {shown0}, after {shown1}")
        if len(shown0) != 1 or len(shown1) != 1:
            failures.append(f"the viewer shows {len(shown0)} then {len(shown1)} images, want 1")
        elif shown0 == shown1:
            failures.append(f"the viewer key did not change the displayed image ({shown0[0]})")
        if pixels0 == pixels1:
            failures.append("the viewer key did not change the pixels on screen")
        driver.save_screenshot(os.path.join(shot_dir, "viewer.png"))
        # Space again flips back to the reference.
        ActionChains(driver).send_keys(" ").perform()
        if driver.execute_script(visible_src, viewer) != shown0:
            failures.append("a second space did not flip back to the reference")
        # Exposure: '+' raises it; the stack then carries the linear-RGB filter.
        ActionChains(driver).send_keys("+").perform()
        ev = viewer.find_element(By.CSS_SELECTOR, ".ev").text
        filt = driver.execute_script("return arguments[0].style.filter", stack)
        if ev != "+0.5 EV" or "url(" not in filt:
            failures.append(f"exposure key: label {ev!r}, filter {filt!r}")
        if stack.screenshot_as_png == pixels0:
            failures.append("raising the exposure did not change the pixels on screen")
        # A detail table, collapsed, builds its rows when opened and sorts on a header click.
        driver.execute_script("document.querySelector('#t-metrics summary').click()")
        time.sleep(0.1)
        table = driver.execute_script(
            "const d = document.querySelector('#t-metrics'); const th = d.querySelectorAll('th')[4];"
            "th.click(); const col = Array.from(d.querySelectorAll('tbody tr'))"
            ".map(r => parseFloat(r.cells[4].textContent));"
            "return [d.open, th.getAttribute('aria-sort'), col]")
        opened, sort, col = table
        want_rows = len(open(os.path.join(study_dir, "results.csv")).read().splitlines()) - 1
        if not opened or sort != "ascending" or len(col) != want_rows or col != sorted(col):
            failures.append(f"metrics table: open {opened}, sort {sort}, {len(col)} rows "
                            f"(want {want_rows}), sorted {col == sorted(col)}")

        errors = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
        for e in errors:
            failures.append(f"console error: {e.get('message')}")
    finally:
        driver.quit()
    for f in failures:
        print("FAILED: " + f)
    if not failures:
        print(f"PASS: screenshots in {shot_dir} (top.png, viewer.png)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
