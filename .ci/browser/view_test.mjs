// Browser test of `flexsurf view`: opens a run's view.html headless in Debian's Chromium (driven by
// playwright-core, with no browser download) and checks, from a screenshot's pixels and from what the page
// reports through window.flexsurfView, that the cloth and the obstacle are drawn, that scrubbing the frame
// slider changes the shape, that the field selector recolours the cloth, and that nothing logs an error.
//
// Usage: node view_test.mjs RUN_DIR/view.html [SCREENSHOT_DIR]
// Environment: CHROMIUM (default /usr/bin/chromium). Exit status 0 when every check passes, 1 otherwise.
import { chromium } from "playwright-core";
import path from "node:path";
import fs from "node:fs";

const [htmlPath, shotDir] = process.argv.slice(2);
if (!htmlPath) {
  console.error("usage: node view_test.mjs RUN_DIR/view.html [SCREENSHOT_DIR]");
  process.exit(2);
}
const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures.push(what);
};

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  headless: true,
  // Software WebGL2 (SwiftShader through ANGLE); no network traffic of the browser's own.
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
         "--disable-quic"],
});
const errors = [];
let code = 1;
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 700 } });
  page.on("console", (m) => { if (m.type() === "error") errors.push(`console: ${m.text()}`); });
  page.on("pageerror", (e) => errors.push(`page: ${e.message}`));
  page.on("requestfailed", (r) => errors.push(`request failed: ${r.url()}`));
  const requests = [];
  page.on("request", (r) => { if (!r.url().startsWith("file:") && !r.url().startsWith("data:")) requests.push(r.url()); });
  await page.goto("file://" + path.resolve(htmlPath));
  await page.waitForFunction(() => window.flexsurfView && (window.flexsurfView.ready || window.flexsurfView.errors.length), null, { timeout: 60000 });
  const ready = await page.evaluate(() => window.flexsurfView.ready);
  if (!ready) {
    const reported = await page.evaluate(() => window.flexsurfView.errors);
    check(false, `the page is ready (it reported: ${reported.concat(errors).join(" | ")})`);
    throw new Error("the viewer did not start");
  }
  check(true, "the page is ready");
  const stats0 = await page.evaluate(() => window.flexsurfView.setFrame(0));
  console.log("stats at frame 0:", JSON.stringify(stats0));
  check(stats0.frames >= 2, `the page reports ${stats0.frames} frames (at least 2)`);
  check(stats0.clothTriangles > 0 && stats0.lastDraw && stats0.lastDraw.cloth === stats0.clothTriangles,
        `the cloth is drawn (${stats0.clothTriangles} triangles)`);
  check(stats0.obstacles >= 1 && stats0.obstacleTriangles > 0 && stats0.lastDraw.obstacles === stats0.obstacles,
        `the obstacle is drawn (${stats0.obstacles} obstacle(s), ${stats0.obstacleTriangles} triangles)`);

  // Pixels of a screenshot of the WebGL canvas, classified in the page (a 2D canvas decodes the PNG).
  const canvas = page.locator("#gl");
  const classify = async (png) => page.evaluate(async (b64) => {
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const bmp = await createImageBitmap(new Blob([bytes], { type: "image/png" }));
    const c = new OffscreenCanvas(bmp.width, bmp.height);
    const g = c.getContext("2d");
    g.drawImage(bmp, 0, 0);
    const d = g.getImageData(0, 0, bmp.width, bmp.height).data;
    let cloth = 0, obstacle = 0, other = 0, coloured = 0;
    for (let i = 0; i < d.length; i += 4) {
      const [r, gg, b] = [d[i], d[i + 1], d[i + 2]];
      if (r > 50 && r > 1.4 * gg && r > 1.4 * b) cloth++;
      else if (b >= r + 3 && b < 235 && b - r < 70 && gg + 8 >= r) obstacle++;
      else other++;
      if (Math.max(r, gg, b) - Math.min(r, gg, b) > 60 && !(r > 1.4 * gg && r > 1.4 * b)) coloured++;
    }
    return { width: bmp.width, height: bmp.height, total: d.length / 4, cloth, obstacle, other, coloured };
  }, png.toString("base64"));
  const diff = async (a, b) => page.evaluate(async ([a64, b64]) => {
    const load = async (s) => {
      const bytes = Uint8Array.from(atob(s), (c) => c.charCodeAt(0));
      const bmp = await createImageBitmap(new Blob([bytes], { type: "image/png" }));
      const c = new OffscreenCanvas(bmp.width, bmp.height);
      const g = c.getContext("2d");
      g.drawImage(bmp, 0, 0);
      return g.getImageData(0, 0, bmp.width, bmp.height).data;
    };
    const [x, y] = [await load(a64), await load(b64)];
    let n = 0;
    for (let i = 0; i < x.length; i += 4) {
      if (Math.abs(x[i] - y[i]) + Math.abs(x[i + 1] - y[i + 1]) + Math.abs(x[i + 2] - y[i + 2]) > 30) n++;
    }
    return n / (x.length / 4);
  }, [a.toString("base64"), b.toString("base64")]);

  const shot0 = await canvas.screenshot();
  const px0 = await classify(shot0);
  console.log("pixels at frame 0:", JSON.stringify(px0));
  check(px0.cloth > 0.02 * px0.total, `cloth-coloured pixels at frame 0: ${px0.cloth} of ${px0.total} (> 2 %)`);
  check(px0.obstacle > 0.005 * px0.total, `obstacle-coloured pixels at frame 0: ${px0.obstacle} of ${px0.total} (> 0.5 %)`);

  // Scrub with the slider (its input event, as a drag would send) to the last frame.
  const last = stats0.frames - 1;
  await page.evaluate((k) => {
    const s = document.getElementById("frame");
    s.value = String(k);
    s.dispatchEvent(new Event("input", { bubbles: true }));
  }, last);
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const statsN = await page.evaluate(() => window.flexsurfView.stats());
  console.log("stats at the last frame:", JSON.stringify(statsN));
  check(statsN.frame === last, `the slider moved the page to frame ${statsN.frame} (expected ${last})`);
  const drop = stats0.clothZ[1] - statsN.clothZ[1];
  check(Math.abs(drop) > 0.01 || Math.abs(stats0.clothMeanZ - statsN.clothMeanZ) > 0.01,
        `the shape changed: top of the cloth ${stats0.clothZ[1].toFixed(3)} m -> ${statsN.clothZ[1].toFixed(3)} m`);
  const shotN = await canvas.screenshot();
  const pxN = await classify(shotN);
  const changed = await diff(shot0, shotN);
  console.log("pixels at the last frame:", JSON.stringify(pxN), "changed fraction:", changed.toFixed(4));
  check(changed > 0.01, `scrubbing changed ${(100 * changed).toFixed(2)} % of the pixels (> 1 %)`);
  check(pxN.cloth > 0.02 * pxN.total, `cloth-coloured pixels at the last frame: ${pxN.cloth}`);

  // The field selector recolours the cloth (strain: colour-ramp pixels instead of the plain cloth colour).
  await page.selectOption("#field", "strain");
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const pxS = await classify(await canvas.screenshot());
  console.log("pixels coloured by strain:", JSON.stringify(pxS));
  check((await page.evaluate(() => window.flexsurfView.field)) === "strain", "the field selector chose strain");
  check(pxS.coloured > 0.01 * pxS.total && pxS.cloth < pxN.cloth, `strain colours on the cloth: ${pxS.coloured} pixels`);

  // The play button plays at the simulated speed: after 1.5 s of a run whose frames are under 1.5 s apart, the
  // page has moved on from the first frame (or shows a blend between two); the button then pauses it.
  await page.evaluate(() => window.flexsurfView.setFrame(0));
  await page.click("#play");
  await page.waitForTimeout(1500);
  const playing = await page.evaluate(() => ({ frame: window.flexsurfView.frame, label: document.getElementById("time").textContent }));
  await page.click("#play");
  const gap = stats0.frames > 1 ? statsN.time / (stats0.frames - 1) : Infinity;
  if (gap < 1.4) {
    check(playing.frame > 0 || /blended/.test(playing.label), `play moved the picture on: "${playing.label}"`);
  }
  check((await page.textContent("#play")) === "play", "the play button paused the playback");

  if (shotDir) {
    fs.mkdirSync(shotDir, { recursive: true });
    fs.writeFileSync(path.join(shotDir, "view_frame0.png"), shot0);
    fs.writeFileSync(path.join(shotDir, "view_last.png"), shotN);
  }
  const hookErrors = await page.evaluate(() => window.flexsurfView.errors);
  errors.push(...hookErrors.map((e) => `page reported: ${e}`));
  check(requests.length === 0, `no network requests (${requests.join(", ") || "none"})`);
  check(errors.length === 0, `no console or page errors${errors.length ? ": " + errors.join(" | ") : ""}`);
  code = failures.length ? 1 : 0;
} catch (e) {
  failures.push(e.message);
  console.error("FAIL the browser test stopped:", e.message);
  if (errors.length) console.error("errors seen:", errors.join(" | "));
} finally {
  await browser.close();
}
if (code !== 0) console.error(`browser test: ${failures.length} check(s) failed`);
process.exit(code);
