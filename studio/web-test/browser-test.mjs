// Real-browser test of the studio's web bundle: Debian's chromium, headless, driven by
// playwright-core. Serves target/studio-web/ from an in-process static server on 127.0.0.1,
// then, as a user would:
//   1. opens the page on the built-in courtyard and waits for the first decision;
//   2. opens a map (map.yaml + map.pgm) through the file picker (Ctrl+O);
//   3. drops a landmark set (landmarks.ply) on the canvas and answers "Landmarks" in the dialog;
//   4. drags the α slider to its end and checks that the ranking changed;
//   5. clicks the best candidate, drags the robot, and times re-ranking over many slider moves;
//   6. reloads without a query: the default built-in scene shows with a decision made; then
//      records a short mission as a rosbag2 bag with the native CLI, opens it through the picker
//      and by drop, steps to the next decision, and checks each instant's re-ranking against
//      `fitslam select --bag --at` (target/debug/fitslam);
//   7. opens the Mission mode, plays fit / greedy / random side by side on the paper world until
//      time advances and every lane explores, then measures the simulated seconds per real second
//      as fast as the frame budget allows (three lanes, then one): mission_speed.json. On the way
//      it pauses and checks every lane's metrics.csv against the native CLI (target/debug/fitslam,
//      built by `cargo test`) for the same world, strategy and seed: same seed, same run, in both;
//      then once more with graph SLAM (one fit lane, 20 s);
//   8. runs two whole paper-world missions in wasm through the bundle's run_mission (ground truth,
//      and graph SLAM with the reproducible factorisation) and compares their metrics.csv and
//      trajectory_est.tum with the native CLI's, byte for byte.
// The canvas has no DOM, so the app publishes its state: document.title (a digest of the
// ranking) and window.fitslam.{ranking, stats, widgets} (JSON; widget rectangles in CSS px).
// Screenshots go to target/studio-web-test/, with timing.json. Prints "N passed, N failed".
//
// Usage: node browser-test.mjs [bundle dir] [output dir]   (env CHROMIUM overrides the binary)

import { chromium } from "playwright-core";
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import os from "node:os";
import { fileURLToPath } from "node:url";
import { execFileSync } from "node:child_process";

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, "../..");
// The target dir as cargo sees it (build-web.sh writes under $CARGO_TARGET_DIR when set).
const targetDir = path.resolve(repo, process.env.CARGO_TARGET_DIR ?? "target");
const bundle = path.resolve(process.argv[2] ?? path.join(targetDir, "studio-web"));
const outDir = path.resolve(process.argv[3] ?? path.join(targetDir, "studio-web-test"));
const assetDir = path.join(repo, "assets/maps/jacksboro");
const executablePath = process.env.CHROMIUM ?? "/usr/bin/chromium";
fs.mkdirSync(outDir, { recursive: true });

let passed = 0;
let failed = 0;
function check(name, ok, detail = "") {
  if (ok) {
    passed++;
    console.log(`ok   - ${name}${detail ? ": " + detail : ""}`);
  } else {
    failed++;
    console.log(`FAIL - ${name}${detail ? ": " + detail : ""}`);
  }
  return ok;
}

// --- static server -------------------------------------------------------------------------
const mime = { ".html": "text/html", ".js": "text/javascript", ".wasm": "application/wasm", ".css": "text/css", ".json": "application/json" };
const server = http.createServer((req, res) => {
  const url = new URL(req.url, "http://127.0.0.1");
  let file = path.normalize(path.join(bundle, decodeURIComponent(url.pathname)));
  if (!file.startsWith(bundle)) { res.writeHead(403); res.end(); return; }
  if (fs.existsSync(file) && fs.statSync(file).isDirectory()) file = path.join(file, "index.html");
  fs.readFile(file, (err, data) => {
    if (err) { res.writeHead(404); res.end("not found"); return; }
    res.writeHead(200, { "Content-Type": mime[path.extname(file)] ?? "application/octet-stream" });
    res.end(data);
  });
});
await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
const base = `http://127.0.0.1:${server.address().port}/`;

// --- browser -------------------------------------------------------------------------------
const browser = await chromium.launch({
  executablePath,
  headless: true,
  args: [
    "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
  ],
});
const page = await browser.newPage({ viewport: { width: 1400, height: 900 } });
const consoleErrors = [];
page.on("console", (m) => { if (m.type() === "error") consoleErrors.push(m.text()); });
page.on("pageerror", (e) => consoleErrors.push(String(e)));
// Arm file-chooser interception before anything can open one (arming is asynchronous).
const choosers = [];
page.on("filechooser", (fc) => choosers.push(fc));

const state = () => page.evaluate(() => {
  const f = window.fitslam;
  if (!f) return null;
  return { title: document.title, ranking: f.ranking, stats: JSON.parse(f.stats), widgets: JSON.parse(f.widgets) };
});
async function waitFor(name, pred, timeoutMs = 30000) {
  const t0 = Date.now();
  let s = null;
  while (Date.now() - t0 < timeoutMs) {
    s = await state();
    if (s && pred(s)) return s;
    await page.waitForTimeout(100);
  }
  check(name, false, `timed out; last state: ${JSON.stringify(s?.stats ?? null)}`);
  return null;
}

// The state once the widget rectangles have settled (two reads 150 ms apart agree). A click that
// changes the layout (a menu closes, a checkbox changes a label) moves widgets in the frame
// *after* the one that handled it, and a state read in between carries the old rectangles: a
// click there can land on another button (it once hit "Step decision" instead of "Play").
async function settledState(timeoutMs = 5000) {
  const t0 = Date.now();
  let a = await state();
  while (Date.now() - t0 < timeoutMs) {
    await page.waitForTimeout(150);
    const b = await state();
    if (a && b && JSON.stringify(a.widgets) === JSON.stringify(b.widgets)) return b;
    a = b;
  }
  return a;
}

// Screenshot and a measure of how much is drawn: distinct colours (quantised) and the share of
// pixels that differ from the most common colour.
async function shot(name) {
  const file = path.join(outDir, name);
  const png = await page.screenshot({ path: file });
  const m = await page.evaluate(async (b64) => {
    const img = new Image();
    img.src = "data:image/png;base64," + b64;
    await img.decode();
    const c = document.createElement("canvas");
    c.width = img.width; c.height = img.height;
    const g = c.getContext("2d");
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const counts = new Map();
    for (let i = 0; i < d.length; i += 4) {
      const k = ((d[i] >> 3) << 10) | ((d[i + 1] >> 3) << 5) | (d[i + 2] >> 3);
      counts.set(k, (counts.get(k) ?? 0) + 1);
    }
    const n = d.length / 4;
    const top = Math.max(...counts.values());
    return { colours: counts.size, nonBackground: 1 - top / n };
  }, png.toString("base64"));
  return { file, ...m };
}
// Pauses the missions and compares every lane's metrics.csv so far with the native CLI's
// (target/debug/fitslam, built by `cargo test`) for the same world, strategy, seed and
// localisation. Returns the paused state.
async function sameRunAsNative() {
  let s = await state();
  await page.mouse.click(...center(rect(s, "mission_pause")));
  s = await waitFor("mission paused with its metrics published",
    (s) => s.stats.mission.state === "Paused" && s.stats.mission.lanes.every((l) => typeof l.metrics_csv === "string"), 60000);
  if (!s) return s;
  const m = s.stats.mission;
  const cli = path.join(targetDir, "debug", process.platform === "win32" ? "fitslam.exe" : "fitslam");
  for (const lane of m.lanes) {
    const wasmLines = lane.metrics_csv.split("\n").filter((l) => l.length > 0);
    let detail;
    let same = false;
    try {
      const dir = fs.mkdtempSync(path.join(os.tmpdir(), "fitslam-native-"));
      const simParams = [];
      if (m.reproducible_slam) {
        fs.writeFileSync(path.join(dir, "sim.toml"), '[slam.graph.optimizer]\nfactorisation = "reproducible"\n');
        simParams.push("--sim-params", path.join(dir, "sim.toml"));
      }
      execFileSync(cli, ["explore", "--world", path.join(repo, "assets/worlds", `${m.world}.toml`), "--strategy", lane.strategy_id,
        "--seed", String(m.seed), "--localisation", m.localisation_id.replaceAll("_", "-"), ...simParams,
        "--time-limit-s", String(Math.ceil(lane.time_s) + 3), "--out", path.join(dir, "out")], { stdio: "pipe" });
      const nativeLines = fs.readFileSync(path.join(dir, "out", "metrics.csv"), "utf8").split("\n").filter((l) => l.length > 0);
      fs.rmSync(dir, { recursive: true, force: true });
      const k = wasmLines.findIndex((l, i) => l !== nativeLines[i]);
      same = wasmLines.length >= 2 && k === -1;
      detail = same ? `${wasmLines.length - 1} rows to t = ${lane.time_s.toFixed(1)} s identical`
        : `first difference at line ${k + 1}: wasm "${wasmLines[k]}" vs native "${nativeLines[k]}"`;
    } catch (e) {
      detail = `native run failed (${cli}): ${String(e.message ?? e).split("\n")[0]}`;
    }
    const factorisation = m.reproducible_slam ? ", reproducible factorisation" : "";
    check(`${lane.strategy} lane, ${m.localisation}${factorisation}: the same metrics as the native CLI (seed ${m.seed})`, same, detail);
  }
  return s;
}

// Drops the file at `file` on the canvas under the name `name`, as a user dragging it there.
async function dropFile(file, name) {
  const b64 = fs.readFileSync(file).toString("base64");
  await page.evaluate(async ([b64, name]) => {
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const dt = new DataTransfer();
    dt.items.add(new File([bytes], name, { type: "application/octet-stream" }));
    const canvas = document.getElementById("fitslam_canvas");
    const r = canvas.getBoundingClientRect();
    const at = { clientX: r.left + r.width / 2, clientY: r.top + r.height / 2 };
    for (const type of ["dragenter", "dragover", "drop"]) {
      canvas.dispatchEvent(new DragEvent(type, { dataTransfer: dt, bubbles: true, cancelable: true, ...at }));
    }
  }, [b64, name]);
}

// The native CLI's view of a bag: its decision instants and its choice at two of them.
function nativeBag(dir) {
  const cli = path.join(targetDir, "debug", process.platform === "win32" ? "fitslam.exe" : "fitslam");
  const bag = path.join(dir, "mission.mcap");
  execFileSync(cli, ["explore", "--world", path.join(repo, "assets/worlds/paper_unstructured_20m.toml"), "--strategy", "fit",
    "--seed", "1", "--localisation", "ground-truth", "--time-limit-s", "60", "--out", path.join(dir, "out"), "--bag", bag], { stdio: "pipe" });
  const info = JSON.parse(execFileSync(cli, ["bag-info", bag, "--json"], { encoding: "utf8" }));
  const instants = info.decision_instants.map((i) => i.t_s);
  const chosen = instants.slice(0, 2).map((t) => {
    const d = JSON.parse(execFileSync(cli, ["select", "--bag", bag, "--at", String(t), "--json"], { encoding: "utf8" }));
    return d.chosen === null ? null : [d.candidates[d.chosen].x, d.candidates[d.chosen].y];
  });
  return { bag, instants, chosen };
}

async function recordedMission() {
  let native;
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), "fitslam-bag-"));
  try {
    native = nativeBag(dir);
  } catch (e) {
    check("the native CLI records a mission bag", false, String(e.message ?? e).split("\n")[0]);
    return;
  }
  check("the native CLI records a mission bag with two decisions or more", native.instants.length >= 2, `${native.instants.length} instants`);
  const sameChoice = (s, k) => JSON.stringify(s.stats.recording.chosen_m) === JSON.stringify(native.chosen[k]);

  let s = await state();
  await page.mouse.click(...center(rect(s, "canvas")));
  await page.keyboard.press("Control+o");
  for (let k = 0; k < 100 && choosers.length === 0; k++) await page.waitForTimeout(100);
  const chooser = choosers.shift();
  if (!check("Ctrl+O opens the file picker for the bag", chooser !== undefined)) return;
  await chooser.setFiles([native.bag]);
  s = await waitFor("bag opened through the picker", (s) => s.stats.recording?.name === "mission.mcap" && s.stats.recording.chosen_m !== undefined, 60000);
  if (!s) return;
  const r = s.stats.recording;
  check("the studio finds the CLI's decision instants", JSON.stringify(r.instants_s) === JSON.stringify(native.instants),
    `${r.instants_s.length} instants, first at ${r.instants_s[0]} s`);
  check("it opens at the first decision", r.index === 0 && r.t_s === native.instants[0], `t = ${r.t_s} s`);
  check("the robot's choice is recorded", Array.isArray(r.robot_goal), JSON.stringify(r.robot_goal));
  s = await waitFor("re-ranked at the first decision as `fitslam select --bag --at` does", (s) => sameChoice(s, 0), 10000);
  if (s) check("first decision: the studio and the CLI choose the same goal", true, `${JSON.stringify(native.chosen[0])}, ${s.stats.recording.goal_gap_m} m from the robot's`);
  notBlank("recording screenshot", await shot("06b-recording.png"));

  s = await settledState();
  await page.mouse.click(...center(rect(s, "bag_next")));
  s = await waitFor("next decision shown", (s) => s.stats.recording?.index === 1, 20000);
  if (s) {
    check("next decision: the instant of the CLI's second decision", s.stats.recording.t_s === native.instants[1], `t = ${s.stats.recording.t_s} s`);
    s = await waitFor("re-ranked at the second decision", (s) => sameChoice(s, 1), 10000);
    if (s) check("second decision: the studio and the CLI choose the same goal", true, JSON.stringify(native.chosen[1]));
  }

  await dropFile(native.bag, "dropped.mcap");
  s = await waitFor("bag opened by drop", (s) => s.stats.recording?.name === "dropped.mcap", 60000);
  if (s) check("a dropped bag opens at its first decision", s.stats.recording.index === 0 && sameChoice(s, 0), `t = ${s.stats.recording.t_s} s`);
  fs.rmSync(dir, { recursive: true, force: true });
}

function notBlank(name, m) {
  return check(`${name} is not blank`, m.colours >= 50 && m.nonBackground >= 0.2, `${m.colours} colours, ${(100 * m.nonBackground).toFixed(0)}% drawn (${path.relative(repo, m.file)})`);
}
const rect = (s, k) => s.widgets[k];
const center = (r) => [r[0] + r[2] / 2, r[1] + r[3] / 2];

try {
  // 1. Start on a built-in asset.
  await page.goto(base + "?asset=courtyard");
  let s = await waitFor("first decision", (s) => s.ranking !== "null" && s.title.startsWith("fitslam: chosen="));
  if (!s) throw new Error("the studio did not start");
  check("starts on the requested built-in asset", s.stats.map === "courtyard", s.stats.map);
  check("title shows the ranking", /^fitslam: chosen=\d+ top=\[\(\d+,/.test(s.title), s.title);
  notBlank("start screenshot", await shot("01-start.png"));
  const startTitle = s.title;

  // 2. Open a map through the file picker (Ctrl+O opens it; the browser's picker is answered).
  await page.mouse.click(...center(rect(s, "canvas")));
  await page.waitForTimeout(300);
  await page.keyboard.press("Control+o");
  for (let k = 0; k < 100 && choosers.length === 0; k++) await page.waitForTimeout(100);
  const chooser = choosers.shift();
  if (!check("Ctrl+O opens the file picker", chooser !== undefined)) throw new Error("no file picker");
  check("the picker accepts several files", chooser.isMultiple());
  await chooser.setFiles([path.join(assetDir, "map.yaml"), path.join(assetDir, "map.pgm")]);
  s = await waitFor("map loaded through the picker", (s) => s.stats.map === "map.yaml");
  if (s) {
    check("map from the picker is 400 × 400", JSON.stringify(s.stats.map_cells) === "[400,400]", JSON.stringify(s.stats.map_cells));
    check("ranking changed with the map", s.title !== startTitle, `${startTitle} -> ${s.title}`);
  }

  // 3. Drop a landmark set on the canvas; the studio asks what the cloud is.
  await dropFile(path.join(assetDir, "landmarks.ply"), "landmarks.ply");
  s = await waitFor("dropped cloud asks what it is", (s) => s.stats.cloud_question === "landmarks.ply" && rect(s, "cloud_landmarks"));
  if (s) {
    // The question window lays itself out over its first frames: click where it settled (one
    // CI run clicked the first frame's rectangle and missed).
    s = await settledState();
    await page.mouse.click(...center(rect(s, "cloud_landmarks")));
    s = await waitFor("dropped landmarks loaded", (s) => s.stats.landmarks === "landmarks.ply");
    if (s) check("1196 landmarks", s.stats.landmark_points === 1196, String(s.stats.landmark_points));
  }
  notBlank("loaded screenshot", await shot("02-loaded.png"));

  // 4. Move a parameter: drag α's slider to its right end.
  s = await state();
  const before = s;
  const a = rect(s, "alpha");
  const width = s.stats.slider_width;
  const y = a[1] + a[3] / 2;
  const x0 = a[0] + width * s.stats.params.alpha;
  await page.mouse.move(x0, y);
  await page.mouse.down();
  await page.mouse.move(x0 + 30, y, { steps: 3 });
  await page.mouse.move(a[0] + width + 40, y, { steps: 5 });
  await page.mouse.up();
  s = await waitFor("α moved", (s) => s.stats.params.alpha > 0.99);
  if (s) {
    check("α slider reached 1", s.stats.params.alpha === 1, String(s.stats.params.alpha));
    check("ranking changed after moving α", s.ranking !== before.ranking && s.stats.decision_revision > before.stats.decision_revision,
      `${before.title} -> ${s.title}`);
  }
  notBlank("after-α screenshot", await shot("03-alpha.png"));

  // 5a. Click the best candidate (selects it; its rays and cone are drawn).
  s = await state();
  if (rect(s, "rank1")) {
    await page.mouse.click(...center(rect(s, "rank1")));
    await page.waitForTimeout(300);
    notBlank("selected-candidate screenshot", await shot("04-selected.png"));
  }
  // 5b. Drag the robot.
  s = await state();
  const robotBefore = s.stats.robot;
  const rc = center(rect(s, "robot"));
  await page.mouse.move(rc[0], rc[1]);
  await page.mouse.down();
  await page.mouse.move(rc[0] + 15, rc[1] - 10, { steps: 3 });
  await page.mouse.move(rc[0] + 40, rc[1] - 25, { steps: 4 });
  await page.mouse.up();
  s = await waitFor("robot moved", (s) => s.stats.robot[0] !== robotBefore[0] && s.stats.error === null);
  if (s) check("robot dragged to a new pose and re-ranked", s.stats.robot[0] !== robotBefore[0] && s.stats.error === null, `${robotBefore} -> ${s.stats.robot}`);

  // 5c. Re-ranking time in the browser: β moved across its range, one decision per move.
  const times = [];
  s = await state();
  const b = rect(s, "beta");
  for (let k = 0; k < 20; k++) {
    const prev = (await state()).stats.decision_revision;
    // Alternate between well separated positions so that every click changes β.
    const x = b[0] + width * (k % 2 === 0 ? 0.25 + 0.01 * k : 0.75 - 0.01 * k);
    await page.mouse.click(x, b[1] + b[3] / 2);
    const t = await waitFor(`decision after β move ${k}`, (s) => s.stats.decision_revision > prev, 10000);
    if (!t) break;
    times.push(t.stats.decision_ms);
  }
  times.sort((p, q) => p - q);
  const median = times[Math.floor(times.length / 2)];
  const max = times[times.length - 1];
  s = await state();
  const timing = { map: s.stats.map, map_cells: s.stats.map_cells, landmarks: s.stats.landmark_points, decisions: times.length, median_ms: median, max_ms: max, all_ms: times };
  fs.writeFileSync(path.join(outDir, "timing.json"), JSON.stringify(timing, null, 2));
  check("re-ranking timed in the browser", times.length >= 10, `median ${median?.toFixed(2)} ms, max ${max?.toFixed(2)} ms over ${times.length} decisions on ${s.stats.map} ${JSON.stringify(s.stats.map_cells)}`);
  notBlank("final screenshot", await shot("05-final.png"));

  // 6. A fresh start without any query shows the default built-in scene with a decision.
  await page.goto(base);
  s = await waitFor("default scene decided", (s) => s.ranking !== "null" && s.title.startsWith("fitslam: chosen="));
  if (s) check("the default scene is jacksboro", s.stats.map === "jacksboro", `${s.stats.map}: ${s.title}`);
  notBlank("default-start screenshot", await shot("06-default.png"));

  // 6b. A recorded mission (on the fresh page: default parameters, as the CLI's): the native CLI
  // records a short paper-world mission as a rosbag2 MCAP bag; the studio opens it through the
  // picker (at its first decision instant), steps to the next decision, and re-ranks each
  // instant as `fitslam select --bag --at` does; then the same bag dropped on the canvas opens.
  await recordedMission();

  // 7. Mission mode: play simulated missions (paper world, fit / greedy / random side by side).
  s = await state();
  await page.mouse.click(...center(rect(s, "mode_mission")));
  s = await waitFor("mission mode opened", (s) => s.stats.mode === "mission" && s.stats.mission?.lanes?.length === 3 && rect(s, "mission_play"), 60000);
  if (s) {
    check("mission mode starts on the paper world with three lanes", s.stats.mission.world === "paper_unstructured_20m" && s.stats.mission.time_s === 0,
      `${s.stats.mission.world}: ${s.stats.mission.lanes.map((l) => l.strategy).join(", ")}`);
    // The button where the latest frame drew it (the first frame of a mode may lay out differently).
    await page.waitForTimeout(300);
    s = await state();
    await page.mouse.click(...center(rect(s, "mission_play")));
    s = await waitFor("mission plays: time advances and unexplored % decreases",
      (s) => s.stats.mission.time_s > 20 && s.stats.mission.lanes.every((l) => l.unexplored_pct < l.first_unexplored_pct), 60000);
    if (s) {
      const m = s.stats.mission;
      check("simulated time > 0 and every lane explores", true,
        `t = ${m.time_s.toFixed(1)} s; unexplored ${m.lanes.map((l) => `${l.strategy} ${l.first_unexplored_pct.toFixed(1)} → ${l.unexplored_pct.toFixed(1)} %`).join(", ")}`);
      check("the plots got points", m.plot_points >= 2 * m.lanes.reduce((n, l) => n + l.rows, 0), `${m.plot_points} points`);
    }
    notBlank("mission screenshot", await shot("07-mission.png"));

    // Same seed, same run, native and wasm (ground truth here, graph SLAM below).
    s = await sameRunAsNative();
    if (s) await page.mouse.click(...center(rect(s, "mission_play")));

    // Speed in the browser: as fast as the per-frame budget allows, three lanes then one.
    const measure = async (label, seconds) => {
      await page.waitForTimeout(1000);
      const a = await state();
      const ta = Date.now();
      await page.waitForTimeout(seconds * 1000);
      const b = await state();
      const tb = Date.now();
      const m = b.stats.mission;
      const rate = (m.time_s - a.stats.mission.time_s) / ((tb - ta) / 1000);
      return { label, lanes: m.lanes.length, load_average: os.loadavg(), sim_s_per_s_per_lane: rate, achieved_speed_reported: m.achieved_speed,
               budget_ms: m.budget_ms, last_frame_ms: m.last_frame_ms, time_s: m.time_s, ended: m.lanes.map((l) => l.end) };
    };
    const speeds = [];
    s = await state();
    await page.mouse.click(...center(rect(s, "mission_max_speed")));
    speeds.push(await measure("fit + greedy + random, as fast as possible", 8));
    // One lane: untick greedy and random, Reset, Play.
    s = await state();
    await page.mouse.click(...center(rect(s, "mission_pause")));
    await page.mouse.click(...center(rect(s, "strategy_greedy")));
    await page.mouse.click(...center(rect(s, "strategy_random")));
    s = await settledState();
    await page.mouse.click(...center(rect(s, "mission_reset")));
    s = await waitFor("one lane after Reset", (s) => s.stats.mission.lanes.length === 1 && s.stats.mission.time_s === 0, 60000);
    if (s) s = await settledState();
    if (s) {
      await page.mouse.click(...center(rect(s, "mission_play")));
      speeds.push(await measure("fit alone, as fast as possible", 8));
    }
    fs.writeFileSync(path.join(outDir, "mission_speed.json"), JSON.stringify(speeds, null, 2));
    for (const v of speeds) {
      check(`mission speed measured (${v.label})`, v.sim_s_per_s_per_lane > 0,
        `${v.sim_s_per_s_per_lane.toFixed(1)} simulated s per real s per lane (${v.lanes} lane(s), budget ${v.budget_ms} ms/frame; meter ${v.achieved_speed_reported?.toFixed(1)}; load ${v.load_average.map((x) => x.toFixed(1)).join(" ")})`);
    }
    notBlank("mission (one lane) screenshot", await shot("08-mission-one-lane.png"));

    // Graph SLAM, one lane (fit): choose it, Reset, play 20 s, compare with the native CLI.
    // Each click on rectangles read after the previous one settled (a popup's first frame may
    // not be where it ends up).
    s = await state();
    await page.mouse.click(...center(rect(s, "mission_pause")));
    s = await settledState();
    await page.mouse.click(...center(rect(s, "mission_localisation")));
    s = await waitFor("localisation menu open", (s) => rect(s, "localisation_slam"), 10000);
    if (s) s = await settledState();
    if (s) {
      await page.mouse.click(...center(rect(s, "localisation_slam")));
      s = await settledState();
      // The "same bits on every CPU" switch (reproducible factorisation): the CLI gets it too.
      await page.mouse.click(...center(rect(s, "mission_reproducible")));
      s = await settledState();
      await page.mouse.click(...center(rect(s, "mission_reset")));
      s = await waitFor("graph SLAM lane, reproducible factorisation, after Reset",
        (s) => s.stats.mission.localisation_id === "slam" && s.stats.mission.reproducible_slam === true
          && s.stats.mission.lanes.length === 1 && s.stats.mission.time_s === 0, 60000);
      if (s) s = await settledState();
    }
    if (s) {
      await page.mouse.click(...center(rect(s, "mission_play")));
      s = await waitFor("graph SLAM mission plays", (s) => s.stats.mission.time_s > 20, 120000);
      if (s) s = await sameRunAsNative();
    }
    s = await state();
  }

  // Whole missions, not just their first seconds: the wasm build's (run_mission, the bundle's own
  // export) against the native CLI's, file for file. Ground truth: both compute their maths with
  // the same libm (core/src/math.rs), so they agree to the bit. Graph SLAM with the reproducible
  // factorisation (faer's simplicial Cholesky, scalar loops): the same; with the default one the
  // native run takes faer's SIMD/FMA kernels and parts from wasm's at t = 497 s.
  const reproducible = '[slam.graph.optimizer]\nfactorisation = "reproducible"\n';
  for (const [world, strategy, seed, localisation, simToml] of [
    ["paper_unstructured_20m", "fit", 1, "ground-truth", null],
    ["paper_unstructured_20m", "fit", 1, "slam", reproducible],
  ]) {
    let detail;
    let same = false;
    try {
      const t0 = Date.now();
      const whole = JSON.parse(await page.evaluate(async ([w, st, sd, loc, sim]) => {
        const m = await import("./fitslam_studio.js");
        return m.run_mission(w, st, BigInt(sd), loc, sim);
      }, [world, strategy, seed, localisation, simToml]));
      const wasmS = (Date.now() - t0) / 1000;
      const dir = fs.mkdtempSync(path.join(os.tmpdir(), "fitslam-native-whole-"));
      const cli = path.join(targetDir, "debug", process.platform === "win32" ? "fitslam.exe" : "fitslam");
      const args = ["explore", "--world", path.join(repo, "assets/worlds", `${world}.toml`), "--strategy", strategy,
        "--seed", String(seed), "--localisation", localisation, "--out", dir];
      if (simToml) {
        fs.writeFileSync(path.join(dir, "sim.toml"), simToml);
        args.push("--sim-params", path.join(dir, "sim.toml"));
      }
      execFileSync(cli, args, { stdio: "pipe" });
      const native = ["metrics.csv", "trajectory_est.tum"].map((f) => fs.readFileSync(path.join(dir, f), "utf8"));
      fs.rmSync(dir, { recursive: true, force: true });
      const ours = [whole.metrics_csv, whole.trajectory_est_tum];
      const differs = ["metrics.csv", "trajectory_est.tum"].filter((_, i) => ours[i] !== native[i]);
      same = differs.length === 0;
      const rows = whole.metrics_csv.trim().split("\n").length - 1;
      detail = same ? `${rows} metrics rows and the trajectory identical, end ${whole.end} (wasm ${wasmS.toFixed(1)} s)`
        : `${differs.join(", ")} differ${differs.length === 1 ? "s" : ""}`;
    } catch (e) {
      detail = String(e.message ?? e).split("\n")[0];
    }
    const how = simToml ? `${localisation}, reproducible factorisation` : localisation;
    check(`a whole ${world} mission (${strategy}, seed ${seed}, ${how}) in wasm is the native CLI's`, same, detail);
  }

  check("no error messages from the studio", !s.stats.messages.some((m) => /panic|failed/i.test(m)), JSON.stringify(s.stats.messages));
  check("no errors in the console", consoleErrors.length === 0, consoleErrors.slice(0, 3).join(" | "));
} catch (e) {
  check("browser test ran to the end", false, String(e && e.stack || e));
  try { await shot("99-failure.png"); } catch {}
} finally {
  await browser.close();
  server.close();
}

console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 && passed > 0 ? 0 : 1);
