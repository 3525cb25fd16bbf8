"""Driving the viewer page in a real browser: `play.py` in a subprocess, headless Chromium through selenium.

CI installs Debian's chromium and chromium-driver (`.ci/run`); where they are missing the browser tests
skip, naming what is missing.
"""

from __future__ import annotations

import io
import shutil
import socket
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
WINDOW = (1280, 800)
PAGE_TIMEOUT_S = 60.0

needs_browser = pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None,
                                   reason="needs chromium and chromedriver (apt-get install chromium chromium-driver)")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


STOP_TIMEOUT_S = 120
"""play.py's shutdown after Ctrl-C took over 60 s once on a loaded 2-core machine."""


class PlayProcess:
    """`scripts/play.py` with the viewer on a free port; stopped with Ctrl-C (SIGINT) at exit."""

    def __init__(self, *args: str, start_timeout_s: float = 300.0):
        self.port = free_port()
        self.url = f"http://localhost:{self.port}"
        # Ctrl-C must reach play.py even when the tests run as a background job, whose children start with SIGINT
        # ignored (and Python then installs no KeyboardInterrupt handler)
        self.proc = subprocess.Popen([sys.executable, "scripts/play.py", "--device", "cpu", "--port", str(self.port),
                                      *args], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        self.output: list[str] = []
        deadline = time.monotonic() + start_timeout_s
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line and self.proc.poll() is not None:
                raise RuntimeError(f"play.py exited with {self.proc.returncode}:\n{''.join(self.output)}")
            self.output.append(line)
            if "sliders" in line or "test actions" in line or "policy " in line:  # the env steps from here on
                return
        raise TimeoutError(f"play.py did not start within {start_timeout_s} s:\n{''.join(self.output)}")

    def stop(self) -> str:
        """Ctrl-C, then the rest of its output."""
        self.proc.send_signal(signal.SIGINT)
        try:
            rest, _ = self.proc.communicate(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:  # never leave a server running behind a failed test
            self.proc.send_signal(signal.SIGUSR1)  # play.py prints every thread's stack: where it hangs
            time.sleep(2.0)
            self.proc.kill()
            rest, _ = self.proc.communicate()
            self.output.append(rest)
            raise TimeoutError(f"play.py did not exit within {STOP_TIMEOUT_S} s of Ctrl-C (killed):\n"
                               f"{''.join(self.output)}") from None
        self.output.append(rest)
        return "".join(self.output)


def chrome():
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    # software WebGL (SwiftShader): the viewer draws with three.js, and CI has no GPU
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={WINDOW[0]},{WINDOW[1]}",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader"):
        options.add_argument(arg)
    options.binary_location = CHROMIUM
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def wait_for(predicate, timeout_s: float = PAGE_TIMEOUT_S, what: str = "condition", driver=None):
    """Poll `predicate` until it returns something true; on time-out the error holds the page's text."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.25)
    page = f"; the page reads:\n{page_text(driver)}" if driver is not None else ""
    raise TimeoutError(f"timed out after {timeout_s} s waiting for {what}{page}")


def text_xpath(text: str, tag: str = "*") -> str:
    """The innermost elements whose text is `text` (viser breaks long labels with <wbr> elements)."""
    return f"//{tag}[normalize-space(.)='{text}' and not(*[normalize-space(.)='{text}'])]"


def element_with_text(driver, text: str):
    from selenium.webdriver.common.by import By

    found = driver.find_elements(By.XPATH, text_xpath(text))
    return found[0] if found else None


def click_text(driver, text: str) -> None:
    """Click the page element whose own text is `text` (a button, a folder's title), and give the page a
    moment to open what it opens."""
    element = wait_for(lambda: element_with_text(driver, text), what=f"'{text}' on the page")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
    element.click()
    time.sleep(1.0)


def input_next_to(driver, label: str):
    """The <input> in the GUI row whose <label> is `label` (a slider's number box, a checkbox)."""
    from selenium.webdriver.common.by import By

    def find():
        found = driver.find_elements(By.XPATH, f"{text_xpath(label, 'label')}/ancestor::*[.//input][1]//input")
        # a slider keeps its value in a hidden input too; the number box is the visible one
        shown = [e for e in found if e.get_attribute("type") != "hidden"]
        return shown[0] if shown else None

    return wait_for(find, what=f"the input of '{label}'")


def type_number(driver, label: str, value: float, attempts: int = 10) -> None:
    """Type `value` into the number box of the row labelled `label` and press Enter, as a user would."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    for _ in range(attempts):
        box = input_next_to(driver, label)
        # viser's number box sits in a zero-height wrapper that selenium takes for hidden: focus it by script,
        # then type with real key events (which the page's handlers receive). Right after a folder opens the
        # focus can be lost to its animation: try again until the box shows the value
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'}); arguments[0].focus(); "
                              "arguments[0].select();", box)
        ActionChains(driver).send_keys(f"{value}", Keys.ENTER).perform()
        time.sleep(0.5)
        try:
            if abs(float(box.get_attribute("value")) - value) < 1e-6:
                return
        except ValueError:
            pass
        time.sleep(1.0)
    raise TimeoutError(f"could not type {value} into '{label}'")


def page_text(driver) -> str:
    from selenium.webdriver.common.by import By

    return driver.find_element(By.TAG_NAME, "body").text


def screenshot_png(driver, attempts: int = 4) -> bytes:
    """The page as PNG. Software WebGL on a busy CI machine can keep the renderer from answering within
    chromedriver's 10 s: ask again."""
    from selenium.common.exceptions import TimeoutException

    for attempt in range(attempts):
        try:
            return driver.get_screenshot_as_png()
        except TimeoutException:
            if attempt == attempts - 1:
                raise
            time.sleep(2.0)


def canvas_image(driver) -> np.ndarray:
    """(H, W, 3) uint8 screenshot of the 3D view (the page left of the control panel)."""
    import imageio.v2 as imageio

    from selenium.webdriver.common.by import By

    image = imageio.imread(io.BytesIO(screenshot_png(driver)))[..., :3]
    panel_left = driver.find_element(By.XPATH, text_xpath("Pause")).rect["x"]
    return image[:, : int(panel_left) - 20]


def changed_pixels(a: np.ndarray, b: np.ndarray, threshold: int = 40) -> np.ndarray:
    """(H, W) bool: where two screenshots differ by more than `threshold` in any channel."""
    return (np.abs(a.astype(np.int16) - b.astype(np.int16)) > threshold).any(-1)
