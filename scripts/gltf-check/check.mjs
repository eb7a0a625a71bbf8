// Checks a .glb that `drape run --export` wrote, with two programs other
// than drape: the Khronos glTF validator, and three.js's GLTFLoader and
// AnimationMixer playing the animation to its end.
//
//   cd scripts/gltf-check && npm install
//   node check.mjs cloth.glb [state.json]
//
// With state.json (`drape run --out`), the last frame three.js shows is
// compared with drape's end positions; the exit status is 1 on a validator
// error or a mismatch larger than 1e-5 m.
import fs from 'fs';
import validator from 'gltf-validator';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

const [file, statePath] = process.argv.slice(2);
if (!file) {
  console.error('usage: node check.mjs FILE.glb [STATE.json]');
  process.exit(2);
}
const bytes = fs.readFileSync(file);
const report = await validator.validateBytes(new Uint8Array(bytes));
const { numErrors, numWarnings, numInfos } = report.issues;
console.log(`validator: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos`);
for (const m of report.issues.messages) console.log(`  ${m.severity === 0 ? 'error' : 'note'} ${m.code} ${m.pointer}`);

const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const gltf = await new GLTFLoader().parseAsync(buffer, '');
const mesh = gltf.scene.getObjectByProperty('type', 'Mesh');
const clip = gltf.animations[0];
const targets = mesh.geometry.morphAttributes.position;
console.log(`three.js ${THREE.REVISION}: ${mesh.geometry.attributes.position.count} vertices, ` +
  `${targets.length} morph targets, clip "${clip.name}" of ${clip.duration.toFixed(3)} s`);
const mixer = new THREE.AnimationMixer(gltf.scene);
const action = mixer.clipAction(clip);
action.setLoop(THREE.LoopOnce);
action.clampWhenFinished = true;
action.play();
mixer.update(clip.duration + 1);
const w = mesh.morphTargetInfluences;
const p = mesh.geometry.attributes.position;
const at = (i) => [0, 1, 2].map((c) => p.getComponent(i, c) + targets.reduce((s, d, k) => s + w[k] * d.getComponent(i, c), 0));
let failed = numErrors > 0;
if (statePath) {
  const state = JSON.parse(fs.readFileSync(statePath, 'utf8'));
  let worst = 0;
  state.positions.forEach((q, i) => { at(i).forEach((x, c) => { worst = Math.max(worst, Math.abs(x - q[c])); }); });
  console.log(`last frame in three.js against drape's end state: largest difference ${worst.toExponential(2)} m`);
  failed ||= worst > 1e-5;
}
process.exit(failed ? 1 : 0);
