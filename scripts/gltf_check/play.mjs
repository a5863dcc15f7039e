// Play a hand GLB in three.js: the first clip at a few times, a bone, a vertex and the morph weights.
import fs from 'fs';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
const buf = fs.readFileSync(process.argv[2]);
const ab = buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength);
new GLTFLoader().parse(ab, '', (gltf) => {
  const scene = gltf.scene;
  let skinned = null;
  scene.traverse((o) => { if (o.isSkinnedMesh) skinned = o; });
  const clip = gltf.animations[0];
  const mixer = new THREE.AnimationMixer(scene);
  mixer.clipAction(clip).play();
  const bone = skinned.skeleton.bones.find((b) => b.name === 'index-finger-phalanx-proximal');
  const out = [];
  for (const t of [0, clip.duration * 0.3, clip.duration * 0.5, clip.duration * 0.75]) {
    mixer.setTime(t);
    scene.updateMatrixWorld(true);
    const tip = new THREE.Vector3();
    skinned.skeleton.bones.find((b) => b.name === 'middle-finger-phalanx-distal').getWorldPosition(tip);
    const v = new THREE.Vector3();
    skinned.getVertexPosition(100, v); skinned.localToWorld(v);
    const infl = skinned.morphTargetInfluences.reduce((a, b) => a + b, 0);
    out.push({t: +t.toFixed(2), mcp_quat: bone.quaternion.toArray().map((x) => +x.toFixed(3)),
              middle_dip_world: tip.toArray().map((x) => +x.toFixed(3)), vertex100: v.toArray().map((x) => +x.toFixed(4)),
              morph_sum: +infl.toFixed(3)});
  }
  console.log(JSON.stringify({three: THREE.REVISION, clip: clip.name, duration: clip.duration, tracks: clip.tracks.length,
    bones: skinned.skeleton.bones.length, morphs: skinned.morphTargetInfluences.length, samples: out}, null, 1));
}, (e) => { console.error('parse failed', e); process.exit(2); });
