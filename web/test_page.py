"""The web page in headless Chromium (Playwright), as CI runs it after `scripts/web`.

For each of the three scenes (fracture, ball_drop, cloth_wind) the page must run 40 simulated frames on WebGPU,
show the body (the native frame checks' pixel statistics, computed on the canvas's pixels) and report its frame
rate and adapter. On the fracture scene a scripted right click on the ball must puncture it (fracture events)
and the ball must lose gas through the hole (its `nRT` falls). Its volume is reported, not checked: a third of a
second after the click the ball is bouncing off the obstacles, and its volume swings by ±2% with the impacts,
more than the leak changes it in 20 frames (`tests/gpu/parity.rs` checks the shrinking over a longer run). On the ball
drop, the positions after 600 steps read back from the page must match the native GPU backend's
(`examples/scene_positions.rs`, lavapipe) within the parity tolerance of
`tests/gpu/parity.rs`: RMS difference below 1e-4 of the scene's size.

The fracture scene runs with contact between surfaces on the GPU, as the page loads it: the test checks that the
contact pass ran at every step.

Headless Chromium's WebGPU runs on its software adapter (SwiftShader) and loses its device at the first present
to a canvas. The page is loaded as a user loads it: it presents to the canvas, finds the device lost in its first
frames, and starts again drawing offscreen and copying each frame into a 2D canvas (the same renderer, the same
state buffers, one read-back per frame more). The test reports which way each scene was drawn.

    .venv/bin/python web/test_page.py [--out DIR]      # DIR: screenshots and results (default target/web-test)

Environment: CHROMIUM (the browser, default `chromium` on PATH), FISSURE_POSITIONS (the native example binary,
default $CARGO_TARGET_DIR/release/examples/scene_positions, CARGO_TARGET_DIR defaulting to target).
"""

import argparse
import functools
import http.server
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parent.parent
WEB = ROOT / "web"
SCENES = ["fracture", "ball_drop", "cloth_wind"]
# Frames each scene runs, and the fracture scene's frame of the right click (a third of a second in: the ball has
# met the first obstacle and is in view). 40 rather than 60: on SwiftShader the fracture page runs at ~3.4 s a
# frame, and the checks read the same with 20 frames fewer (CI's web stage 1.7 minutes shorter).
FRAMES = 40
CLICK = 20
# The smallest share of the canvas the body must cover (the native checks use the same statistic).
MIN_BODY = {"fracture": 0.002, "ball_drop": 0.002, "cloth_wind": 0.002}
PARITY_STEPS = 600


def serve():
    class Quiet(http.server.SimpleHTTPRequestHandler):
        extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, ".wasm": "application/wasm",
                          ".js": "text/javascript"}

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(WEB)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def fail(message):
    print(f"FAIL: {message}", flush=True)
    sys.exit(1)


def wait_for(page, expression, timeout_s, what):
    start = time.time()
    while time.time() - start < timeout_s:
        state = page.evaluate("() => ({ error: window.fissure && window.fissure.error })")
        if state["error"]:
            fail(f"{what}: the page failed: {state['error']}")
        if page.evaluate(expression):
            return time.time() - start
        time.sleep(0.25)
    fail(f"{what}: not within {timeout_s} s")


def open_scene(page, base, scene, extra=""):
    page.goto(f"{base}/index.html?scene={scene}{extra}")
    wait_for(page, "() => window.fissure && window.fissure.ready", 120, f"{scene}: loading")


def frames_done(page, n):
    return f"() => window.fissure.frames >= {n}"


def canvas_check(page, scene, out):
    """The canvas's pixels through the native frame checks' statistics; a PNG of it into `out`."""
    result = page.evaluate(
        """(minBody) => {
            const c = document.getElementById('view');
            let px;
            if (window.fissure.present === 'copy') {
                px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
            } else {
                const copy = document.createElement('canvas');
                copy.width = c.width;
                copy.height = c.height;
                const g = copy.getContext('2d');
                g.drawImage(c, 0, 0);
                px = g.getImageData(0, 0, c.width, c.height).data;
            }
            return window.fissure.check_frame(new Uint8Array(px.buffer), c.width, c.height, minBody);
        }""",
        MIN_BODY[scene],
    )
    page.locator("#view").screenshot(path=str(out / f"{scene}.png"))
    if result:
        fail(f"{scene}: the canvas does not show the body: {result}")


def stats(page):
    return json.loads(page.evaluate("() => window.fissure.serial(() => window.fissure.sim.stats())"))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "target" / "web-test"))
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not (WEB / "pkg" / "fissure_web_bg.wasm").exists():
        fail("web/pkg is missing: run scripts/web first")
    chromium = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        fail("no chromium on PATH (Debian: apt install chromium); set CHROMIUM to the browser")
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    native = Path(os.environ.get("FISSURE_POSITIONS", target / "release" / "examples" / "scene_positions"))
    if not native.exists():
        fail(f"{native} is missing: cargo build --release --features gpu --example scene_positions")

    server = serve()
    base = f"http://127.0.0.1:{server.server_address[1]}"
    results = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, headless=True, args=["--enable-unsafe-webgpu"])
        page = browser.new_page(viewport={"width": 1000, "height": 760})
        console_errors = []
        page.on("console", lambda m: m.type == "error" and "favicon" not in m.text and console_errors.append(m.text))
        page.on("pageerror", lambda e: console_errors.append(str(e)))

        for scene in SCENES:
            open_scene(page, base, scene)
            if scene == "fracture":
                # A third of a second in (the ball is inflated and in view), a right click on it.
                wait_for(page, frames_done(page, CLICK), 600, f"{scene}: {CLICK} frames")
                page.evaluate("() => { window.fissure.paused = true; }")
                wait_for(page, "() => !window.fissure.inFrame", 60, f"{scene}: pausing")
                before = stats(page)
                x, y = page.evaluate("() => window.fissure.serial(() => Array.from(window.fissure.sim.body_pixel(0)))")
                box = page.locator("#view").bounding_box()
                page.mouse.click(box["x"] + x * box["width"] / 960, box["y"] + y * box["height"] / 600, button="right")
                wait_for(page, "() => window.fissure.lastPuncture !== null", 60, f"{scene}: the puncture")
                punctured = page.evaluate("() => window.fissure.lastPuncture")
                if punctured < 1:
                    fail(f"{scene}: the right click at ({x:.0f}, {y:.0f}) px made no fracture event")
                at_puncture = stats(page)
                page.evaluate("() => { window.fissure.paused = false; }")
                wait_for(page, frames_done(page, FRAMES), 900, f"{scene}: {FRAMES} frames")
                after = stats(page)
                if not after["gas"] < at_puncture["gas"]:
                    fail(f"{scene}: gas nRT {at_puncture['gas']:.4f} J at the puncture, "
                         f"{after['gas']:.4f} J {FRAMES - CLICK} frames later: the ball did not leak")
                results[scene] = {"events_before": before["events"], "puncture_events": punctured,
                                  "gas_at_puncture": at_puncture["gas"], "gas_after": after["gas"],
                                  "volume_at_puncture": at_puncture["volume"], "volume_after": after["volume"]}
            else:
                wait_for(page, frames_done(page, FRAMES), 900, f"{scene}: {FRAMES} frames")
            s = stats(page)
            if scene == "fracture":
                steps = round(s["time"] / s["dt"])
                if s["contact_steps"] < steps or any("contact off" in n for n in s["notes"]):
                    fail(f"{scene}: the contact pass should run at each of its {steps} steps: {s}")
                results[scene]["contact_steps"] = s["contact_steps"]
            canvas_check(page, scene, out)
            page.evaluate("() => { window.fissure.paused = true; }")
            wait_for(page, "() => !window.fissure.inFrame", 60, f"{scene}: pausing")
            page.screenshot(path=str(out / f"page_{scene}.png"))
            if not (s["fps"] > 0 and s["frames"] >= FRAMES and s["adapter"]):
                fail(f"{scene}: the page does not report its frame rate and adapter: {s}")
            if abs(s["time"] - s["frames"] / 60) > 1e-6 * max(1, s["frames"]):
                fail(f"{scene}: {s['frames']} frames but {s['time']} s simulated")
            present = page.evaluate("() => [window.fissure.present, window.fissure.fallback]")
            results.setdefault(scene, {}).update(
                {"frames": s["frames"], "time": s["time"], "fps": s["fps"], "sim_ms": s["sim_ms"],
                 "events": s["events"], "adapter": s["adapter"], "present": present[0], "fallback": present[1]})
            how = "into the canvas" if present[0] == "canvas" else "offscreen, copied into the canvas" + (
                f" (after the canvas path failed: {present[1]})" if present[1] else "")
            print(f"{scene}: {s['frames']} frames, t = {s['time']:.3f} s, {s['fps']:.1f} fps, "
                  f"simulation {s['sim_ms']:.0f} ms/frame, {s['events']} fracture events, adapter {s['adapter']}, "
                  f"drawn {how}", flush=True)

        # Parity with the native GPU backend: 600 steps of the ball drop, no frames drawn in between.
        open_scene(page, base, "ball_drop", "&paused")
        web = page.evaluate(f"""async () => {{
            const f = window.fissure;
            await f.serial(() => f.sim.run_steps({PARITY_STEPS}));
            return Array.from(f.sim.positions());
        }}""")
        browser.close()
        if console_errors:
            fail("errors in the page's console: " + " | ".join(console_errors[:5]))

    native_out = subprocess.run([str(native), str(ROOT / "scenes" / "ball_drop.toml"), str(PARITY_STEPS), "gpu"],
                                check=True, capture_output=True, text=True).stdout
    ref = json.loads(native_out)
    q = ref["positions"]
    if len(q) != len(web):
        fail(f"parity: {len(web) // 3} particles in the page, {len(q) // 3} natively")
    n = len(q) // 3
    lo = [min(q[3 * i + k] for i in range(n)) for k in range(3)]
    hi = [max(q[3 * i + k] for i in range(n)) for k in range(3)]
    size = math.dist(lo, hi)
    rms = math.sqrt(sum((a - b) ** 2 for a, b in zip(web, q)) / n)
    results["parity"] = {"steps": PARITY_STEPS, "rms_m": rms, "size_m": size, "native_adapter": ref["adapter"]}
    print(f"parity: {PARITY_STEPS} ball-drop steps, RMS position difference page vs native GPU ({ref['adapter']}) "
          f"{rms:.3e} m = {rms / size:.2e} of the scene's size {size:.3f} m (tolerance 1e-4)", flush=True)
    (out / "results.json").write_text(json.dumps(results, indent=2))
    if not rms <= 1e-4 * size:
        fail(f"parity: RMS difference {rms:.3e} m exceeds 1e-4 of the scene's size {size:.3f} m")
    print(f"web page: all checks passed; screenshots and results in {out}")


if __name__ == "__main__":
    main()
