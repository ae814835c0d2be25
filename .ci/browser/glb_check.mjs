// Checks a run's animation.glb with two independent readers: the Khronos glTF validator (no errors, no
// warnings) and three.js's GLTFLoader with an AnimationMixer (the cloth and the obstacles load, the file holds
// a frame at every animation step of the run (0, every `animation_every` steps, every output step of
// summary.json's frames, the last), the clip `simulation` lasts the run's simulated time, and at each frame's
// time the morph weights pick that frame alone).
//
// Usage: node glb_check.mjs RUN_DIR/animation.glb RUN_DIR/summary.json   (exit status 0 when all checks pass)
import validator from "gltf-validator";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import fs from "node:fs";

const [glbPath, summaryPath] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures.push(what);
};
const bytes = fs.readFileSync(glbPath);
const summary = JSON.parse(fs.readFileSync(summaryPath, "utf8"));

const report = await validator.validateBytes(new Uint8Array(bytes));
const serious = report.issues.messages.filter((m) => m.severity <= 1);
check(report.issues.numErrors === 0 && report.issues.numWarnings === 0,
      `glTF validator: ${report.issues.numErrors} errors, ${report.issues.numWarnings} warnings` +
      (serious.length ? ": " + serious.slice(0, 5).map((m) => `${m.code} ${m.pointer}`).join("; ") : ""));

const ab = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const gltf = await new Promise((resolve, reject) => new GLTFLoader().parse(ab, "", resolve, reject));
const meshes = [];
gltf.scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
const cloth = meshes.find((m) => m.name === "cloth");
check(cloth !== undefined, "three.js: the cloth mesh loads");
check(meshes.some((m) => m.name.startsWith("obstacle_")), `three.js: obstacle meshes load (${meshes.map((m) => m.name).join(", ")})`);
// A static solve's frames share t = 0: the file keys them at 0 s, 1 s, … and says so in its extras.
const extras = gltf.parser.json.extras.flexsurf;
const simulated = extras.animation_times_are_simulated;
const frames = extras.frames.map((f, k) => ({ step: f.step, time: simulated ? f.time : k }));
// The animation steps, derived here from the summary: 0, every animation_every steps, the output steps, the last.
const every = summary.animation_every || summary.output_every;
const wanted = new Set(summary.frames.map((f) => f.step));
if (!summary.static_solve) for (let s = 0; s <= summary.steps; s += every) wanted.add(s);
const want = [...wanted].sort((a, b) => a - b);
const got = frames.map((f) => f.step);
check(want.length === got.length && want.every((s, k) => s === got[k]),
      `the file holds the ${want.length} animation steps (every ${every} steps and the output steps): ` +
      `${got.length} frames, steps ${got.slice(0, 4).join(", ")}${got.length > 4 ? ", …, " + got[got.length - 1] : ""}`);
const clip = gltf.animations[0];
check(clip && Math.abs(clip.duration - frames[frames.length - 1].time) < 1e-6,
      `three.js: the clip lasts ${clip && clip.duration} s (the run: ${frames[frames.length - 1].time} s` +
      `${simulated ? "" : ", keyed by frame index"})`);
check(cloth && cloth.geometry.morphAttributes.position.length === frames.length - 1,
      `three.js: ${cloth && cloth.geometry.morphAttributes.position.length} morph targets for ${frames.length} frames`);
const mixer = new THREE.AnimationMixer(gltf.scene);
const action = mixer.clipAction(clip);
action.setLoop(THREE.LoopOnce);
action.clampWhenFinished = true;
action.play();
let picks = true;
for (let k = 0; k < frames.length; k++) {
  mixer.setTime(frames[k].time);
  const w = Array.from(cloth.morphTargetInfluences);
  const want = w.map((_, t) => (t + 1 === k ? 1 : 0));
  if (w.some((v, t) => Math.abs(v - want[t]) > 1e-4)) {
    picks = false;
    console.log(`  at t = ${frames[k].time} s the weights are ${w.map((v) => v.toFixed(3)).join(", ")}`);
  }
}
check(picks, "three.js: at each frame's time the morph weights show that frame");
if (failures.length) console.error(`glb check: ${failures.length} check(s) failed`);
process.exit(failures.length ? 1 : 0);
