"""The browser viewer (uvms.viz.viewer) in a real browser: headless Chromium (software WebGL) opens the page of a
running Viewer through the Chrome DevTools protocol, and the screenshots must show the robot where its bounding box
projects with the camera the page reports, over the seabed grid.

Skipped only where no Chromium can be found (``apt-get install chromium``; ``UVMS_CHROMIUM`` names
another binary) or viser is not installed. ``UVMS_SCREENSHOTS=DIR`` keeps the screenshots in DIR.
"""

from __future__ import annotations

import base64
import io
import itertools
import json
import os
import re
import shutil
import subprocess
import tempfile
import time

import numpy as np
import pytest
from PIL import Image

from conftest import shipped

viser = pytest.importorskip("viser")
from websockets.sync.client import connect  # noqa: E402  (viser's own dependency)

from uvms.viz import viewer  # noqa: E402
from uvms.viz.viewer.scene import bounding_box, box_corners  # noqa: E402

PORT = 18380
WINDOW = (900, 600)  # [px]
BACKGROUND = np.array([255, 255, 255])  # viser's page background
CHROMIUM_FLAGS = ["--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                  "--no-first-run", "--mute-audio", "--hide-scrollbars"]


def chromium() -> str | None:
    """The Chromium binary: ``UVMS_CHROMIUM``, else the first of the usual names on PATH."""
    named = os.environ.get("UVMS_CHROMIUM")
    if named:
        return named
    return next((path for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
                 if (path := shutil.which(name))), None)


class Browser:
    """One headless Chromium page driven through the DevTools protocol (a websocket, JSON messages)."""

    def __init__(self, binary: str, width: int, height: int) -> None:
        self.profile = tempfile.mkdtemp(prefix="uvms-chromium-")
        self.process = subprocess.Popen([binary, *CHROMIUM_FLAGS, f"--window-size={width},{height}",
                                         "--remote-debugging-port=0", f"--user-data-dir={self.profile}",
                                         "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                        text=True)
        address, deadline = None, time.monotonic() + 30
        while address is None and time.monotonic() < deadline:
            line = self.process.stderr.readline()
            if not line and self.process.poll() is not None:
                break
            found = re.search(r"DevTools listening on (ws://\S+)", line)
            address = found.group(1) if found else None
        if address is None:
            self.close()
            raise RuntimeError(f"{binary} did not start its DevTools endpoint")
        self.socket = connect(address, max_size=None, open_timeout=10)
        self.ids = itertools.count(1)
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]

    def call(self, method: str, session: str | None = None, **params) -> dict:
        ident = next(self.ids)
        self.socket.send(json.dumps({"id": ident, "method": method, "params": params,
                                     **({"sessionId": session} if session else {})}))
        while True:
            reply = json.loads(self.socket.recv(timeout=30))
            if reply.get("id") == ident:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def page(self, method: str, **params) -> dict:
        return self.call(method, session=self.session, **params)

    def evaluate(self, expression: str):
        return self.page("Runtime.evaluate", expression=expression, returnByValue=True)["result"].get("value")

    def screenshot(self) -> np.ndarray:
        """The page as an RGB image (H, W, 3), uint8."""
        data = base64.b64decode(self.page("Page.captureScreenshot", format="png")["data"])
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))

    def settled(self, timeout: float = 20.0) -> np.ndarray:
        """A screenshot once two in a row are the same (WebGL done drawing, fades over)."""
        previous, deadline = None, time.monotonic() + timeout
        while True:
            image = self.screenshot()
            if previous is not None and np.array_equal(image, previous) or time.monotonic() > deadline:
                return image
            previous = image
            time.sleep(0.15)

    def close(self) -> None:
        if getattr(self, "socket", None) is not None:
            self.socket.close()
        self.process.kill()
        self.process.wait()
        shutil.rmtree(self.profile, ignore_errors=True)


@pytest.fixture(scope="module")
def browser():
    binary = chromium()
    if binary is None:
        pytest.skip("no Chromium found (apt-get install chromium, or set UVMS_CHROMIUM): the viewer is not "
                    "tested in a browser here")
    page = Browser(binary, *WINDOW)
    yield page
    page.close()


def keep(image: np.ndarray, name: str, tmp_path) -> None:
    folder = os.environ.get("UVMS_SCREENSHOTS") or tmp_path
    os.makedirs(folder, exist_ok=True)
    Image.fromarray(image).save(os.path.join(folder, name))


def open_page(browser: Browser, shown: viewer.Viewer):
    """Load the viewer's page; returns its client once the page reports the framed camera."""
    browser.page("Page.navigate", url=shown.url)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        clients = list(shown.server.get_clients().values())
        if clients and np.allclose(clients[0].camera.position, shown.scene_frame.position, atol=1e-3) \
                and clients[0].camera.image_width > 0:
            break
        time.sleep(0.05)
    else:
        raise AssertionError("the page never reported the framed camera")
    # the page warns about software WebGL in a toast over the scene: close it
    browser.evaluate("document.querySelectorAll('.mantine-Notification-root button, "
                     ".mantine-Notification-closeButton').forEach(b => b.click())")
    return clients[0]


def type_into(browser: Browser, label: str, text: str) -> None:
    """Type ``text`` and Enter into the number field of the panel's slider labelled ``label``."""
    found = browser.evaluate(f"""(() => {{
      const label = [...document.querySelectorAll('label, div, span')].find(
          e => e.children.length === 0 && e.textContent.trim() === {json.dumps(label)});
      let row = label, input = null;
      while (row && !(input = row.querySelector('input.mantine-NumberInput-input'))) row = row.parentElement;
      if (!input) return false;
      input.focus(); input.select();
      return true;
    }})()""")
    assert found, f"no slider labelled {label!r} in the page"
    browser.page("Input.insertText", text=text)
    for kind in ("keyDown", "keyUp"):
        browser.page("Input.dispatchKeyEvent", type=kind, key="Enter", code="Enter", windowsVirtualKeyCode=13)
    browser.evaluate("document.activeElement.blur()")  # no blinking cursor in the screenshots


def projected_box(client, canvas: dict, lower: np.ndarray, upper: np.ndarray) -> tuple[int, int, int, int]:
    """Pixel rectangle (left, top, right, bottom) of a world box seen by the page's camera (OpenCV
    convention: P_world = R p_camera + t, +z forward, +y down; ``fov`` vertical)."""
    camera = client.camera
    w, x, y, z = camera.wxyz
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    local = (box_corners(lower, upper) - camera.position) @ rotation  # (8, 3), camera frame
    assert np.all(local[:, 2] > 0), "the robot is behind the camera"
    width, height = canvas["width"], canvas["height"]
    focal = (height / 2) / np.tan(camera.fov / 2)
    u = canvas["left"] + width / 2 + focal * local[:, 0] / local[:, 2]
    v = canvas["top"] + height / 2 + focal * local[:, 1] / local[:, 2]
    return int(u.min()), int(v.min()), int(np.ceil(u.max())), int(np.ceil(v.max()))


def test_the_page_shows_the_robot_framed_on_a_seabed_and_follows_the_sliders(browser, tmp_path):
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(arm=[3.0, 1.2, 0.8, 3.0, 0.01])  # the arm out in front
    with viewer.Viewer(robot, q, port=PORT) as shown:
        client = open_page(browser, shown)
        canvas = browser.evaluate("(() => { const r = [...document.querySelectorAll('canvas')].sort("
                                  "(a, b) => b.width * b.height - a.width * a.height)[0].getBoundingClientRect();"
                                  " return {left: r.left, top: r.top, width: r.width, height: r.height}; })()")
        assert canvas["width"] > WINDOW[0] / 2, "the scene must keep most of the page beside the panel"
        full = browser.settled()
        keep(full, "viewer_robot.png", tmp_path)

        shown.visualizer.displayVisuals(False)  # the same page, camera and seabed without the robot
        for handle in shown.triads.handles.values():
            handle.visible = False
        empty = browser.settled()
        keep(empty, "viewer_seabed_only.png", tmp_path)

        left, top, right, bottom = (int(round(canvas[key])) for key in ("left", "top", "width", "height"))
        right, bottom = left + right, top + bottom
        scene = (slice(top, bottom), slice(left, right))
        robot_pixels = np.abs(full.astype(int) - empty.astype(int)).sum(axis=-1) > 30  # (H, W)
        robot_pixels[:top], robot_pixels[bottom:], robot_pixels[:, :left], robot_pixels[:, right:] = (
            False, False, False, False)
        area = (right - left) * (bottom - top)
        # the robot is drawn, and large: a sizeable share of the scene
        assert robot_pixels.sum() > 0.08 * area, robot_pixels.sum() / area
        # where its bounding box projects with the page's camera (a few pixels of antialiasing and shadow aside)
        box = bounding_box(robot, shown.visualizer.visual_model, q)
        u0, v0, u1, v1 = projected_box(client, canvas, *box)
        assert left <= u0 and u1 <= right and top <= v0 and v1 <= bottom, "the robot must be inside the view"
        inside = robot_pixels[max(v0 - 3, 0): v1 + 3, max(u0 - 3, 0): u1 + 3].sum()
        assert inside > 0.97 * robot_pixels.sum()
        assert (u1 - u0) * (v1 - v0) > 0.25 * area, "the camera must be framed on the robot"
        # the seabed grid: most of the scene below the robot is not the page background
        ground = empty[scene][(bottom - top) // 2:]
        assert (np.abs(ground.astype(int) - BACKGROUND).sum(axis=-1) > 30).mean() > 0.5

        shown.visualizer.displayVisuals(True)
        for handle in shown.triads.handles.values():
            handle.visible = True
        type_into(browser, "yaw [rad]", "1.2")  # typed in the page's panel: the vehicle turns
        deadline = time.monotonic() + 10
        while abs(shown.q[6] - np.cos(0.6)) > 1e-9 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert shown.teach.sliders["base_yaw"].value == pytest.approx(1.2)
        np.testing.assert_allclose(shown.q, robot.configuration(base=[0, 0, 0, 0, 0, 1.2],
                                                                arm=robot.arm_configuration(q)), atol=1e-12)
        turned = browser.settled()
        keep(turned, "viewer_robot_turned.png", tmp_path)
        changed = np.abs(turned.astype(int) - full.astype(int)).sum(axis=-1)[scene] > 30
        assert changed.mean() > 0.05
