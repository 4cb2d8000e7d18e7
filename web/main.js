// The page: a scene picker, one Sim per canvas, one frame per animation frame. Everything the test needs is on
// `window.fissure` (the Sim, its stats, a ready flag, errors).
import init, { Sim, scene_names, check_frame } from "./pkg/fissure_web.js";

let canvas = document.getElementById("view");
const stage = document.getElementById("stage");
const picker = document.getElementById("scene");
const status = document.getElementById("status");
const errorBox = document.getElementById("error");
// `?paused` loads the scene without running it (the test steps it itself); `?present=copy` draws offscreen and
// copies each frame into a 2D canvas, for browsers whose WebGPU cannot present to a canvas (headless Chromium on
// its software adapter loses the device at the first present). Without it the page presents to the canvas and,
// should the device be lost in the first frames, starts again in copy mode on a fresh canvas and device.
// `?contact=off` runs the scenes' contact bodies without contact between surfaces.
const params = new URLSearchParams(location.search);
const api = (window.fissure = {
  sim: null, ready: false, error: null, paused: params.has("paused"), frames: 0, inFrame: false, lastPuncture: null,
  present: params.get("present") === "copy" ? "copy" : "canvas", fallback: null,
  contact: params.get("contact") !== "off",
});

function fail(message) {
  api.error = String(message);
  errorBox.style.display = "block";
  errorBox.textContent = api.error;
  status.textContent = "";
}

// Awaits each call to the Sim in turn: a frame and a click never run at the same time.
let queue = Promise.resolve();
function serial(f) {
  const p = queue.then(f);
  queue = p.catch(() => {});
  return p;
}
api.serial = serial;

let generation = 0;
async function load(name) {
  const mine = ++generation;
  api.ready = false;
  api.frames = 0;
  status.textContent = `loading ${name}…`;
  await serial(async () => {
    if (api.sim) api.sim.free();
    api.sim = null;
    api.sim = await Sim.create(canvas, name, api.present === "copy", api.contact);
    api.sim.set_adapter(api.adapter);
  });
  if (mine !== generation) return;
  api.ready = true;
  const tick = async (t) => {
    if (mine !== generation || api.error) return;
    if (!api.paused) {
      api.inFrame = true;
      try {
        await serial(() => api.sim.frame(t));
      } catch (e) {
        if (api.present === "canvas" && api.frames < 5) return fallBack(name, e);
        throw e;
      } finally {
        api.inFrame = false;
      }
      api.frames += 1;
      if (api.frames % 10 === 1) {
        const s = JSON.parse(api.sim.stats());
        api.stats = s;
        status.textContent =
          `${s.title}\nt = ${s.time.toFixed(2)} s · ${s.fps.toFixed(0)} fps · simulation ${s.sim_ms.toFixed(1)} ms/frame · ` +
          `fracture events ${s.events} · pieces ${s.pieces}` +
          (s.volume0 > 0 ? ` · gas volume ${(100 * s.volume / s.volume0).toFixed(0)} %` : "") + "\n" +
          `WebGPU adapter: ${s.adapter} · drawn ${api.present === "copy" ? "offscreen, copied to the canvas" : "into the canvas"}` +
          (api.fallback ? ` (the canvas path lost the device: ${api.fallback})` : "") +
          (s.notes.length ? `\n${s.notes.join("\n")}` : "");
      }
    }
    requestAnimationFrame((t2) => tick(t2).catch(fail));
  };
  requestAnimationFrame((t) => tick(t).catch(fail));
}
api.load = load;

// The device was lost presenting to the canvas: a fresh canvas (one that never had a WebGPU context), a fresh
// device, and frames drawn offscreen and copied in.
async function fallBack(name, e) {
  const why = e && e.message ? e.message : String(e);
  console.warn(`fissure: drawing into the canvas failed (${why}); drawing offscreen and copying instead`);
  api.present = "copy";
  api.fallback = why;
  const fresh = canvas.cloneNode(false);
  canvas.replaceWith(fresh);
  canvas = fresh;
  await load(name);
}

function pixel(e) {
  const r = canvas.getBoundingClientRect();
  return [((e.clientX - r.left) * canvas.width) / r.width, ((e.clientY - r.top) * canvas.height) / r.height];
}
stage.addEventListener("contextmenu", (e) => e.preventDefault());
stage.addEventListener("mousedown", (e) => {
  if (!api.ready) return;
  const [x, y] = pixel(e);
  if (e.button === 2) serial(() => api.sim.puncture(x, y)).then((n) => (api.lastPuncture = n)).catch(fail);
  else if (e.button === 0) serial(() => api.sim.mouse_down(x, y)).catch(fail);
});
window.addEventListener("mousemove", (e) => {
  if (api.ready) {
    const [x, y] = pixel(e);
    serial(() => api.sim.mouse_move(x, y)).catch(fail);
  }
});
window.addEventListener("mouseup", () => api.ready && serial(() => api.sim.mouse_up()).catch(fail));
stage.addEventListener("wheel", (e) => {
  e.preventDefault();
  if (api.ready) serial(() => api.sim.zoom(-e.deltaY / 100)).catch(fail);
}, { passive: false });

try {
  if (!navigator.gpu) {
    throw new Error("This browser has no WebGPU (navigator.gpu is missing). Use a recent Chrome, Edge or Firefox with WebGPU enabled.");
  }
  await init();
  // What the browser says of its adapter (wgpu does not learn its name on the web).
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error("This browser has WebGPU but no adapter for it (is it switched off?).");
  const info = adapter.info || {};
  api.adapter = [info.vendor, info.architecture, info.device, info.description].filter((x) => x).join(" ") || "unnamed";
  api.check_frame = check_frame;
  for (const n of scene_names()) picker.add(new Option(n, n));
  const wanted = params.get("scene");
  if (wanted) picker.value = wanted;
  picker.addEventListener("change", () => load(picker.value).catch(fail));
  document.getElementById("restart").addEventListener("click", () => load(picker.value).catch(fail));
  await load(picker.value);
} catch (e) {
  fail(e && e.message ? e.message : e);
}
