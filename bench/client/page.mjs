// SPDX-License-Identifier: GPL-3.0-or-later
// In-browser half of the client bench: three.js GLTFLoader loads the GLB, an AnimationMixer plays its clip
// the way a game loop does (mixer.update(dt) with increasing times), and at each sample time the skin mesh's
// morphTargetInfluences, the world positions of chosen vertices (Mesh.getVertexPosition: morph targets
// applied on the CPU, then matrixWorld) and the skin's matrixWorld (head motion) are read back. fhRender draws the head for a screenshot.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

let state = null;

function meshObject(gltf, meshIndex) {
  // the three.js Mesh made for glTF mesh `meshIndex` (primitive 0), via the loader's associations
  for (const [object, ref] of gltf.parser.associations) {
    if (object.isMesh && ref.meshes === meshIndex && (ref.primitives ?? 0) === 0) return object;
  }
  throw new Error(`no three.js Mesh for glTF mesh ${meshIndex}`);
}

window.fhLoad = async (url, meshIndex, clipName) => {
  const gltf = await new GLTFLoader().loadAsync(url);
  const scene = new THREE.Scene();
  scene.add(gltf.scene);
  scene.updateMatrixWorld(true);
  const clip = clipName ? gltf.animations.find((c) => c.name === clipName)
    : gltf.animations[0] || new THREE.AnimationClip('static', 0, []);   // a file without animation
  if (!clip) throw new Error(`clip ${clipName} not found (have ${gltf.animations.map((c) => c.name)})`);
  const mixer = new THREE.AnimationMixer(gltf.scene);
  const action = mixer.clipAction(clip);
  action.setLoop(THREE.LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
  const skin = meshObject(gltf, meshIndex);
  const meshes = [];
  gltf.scene.traverse((o) => {
    if (o.isMesh) meshes.push({ name: o.name, vertices: o.geometry.attributes.position.count,
      morphTargets: (o.geometry.morphAttributes.position || []).length,
      attributes: Object.keys(o.geometry.attributes), vertexColors: !!o.material.vertexColors });
  });
  // tracks the mixer actually bound to an object (an unbound track would play nothing)
  const bound = (action._propertyBindings || []).filter((b) => b.binding.node !== undefined && b.binding.node !== null).length;
  state = { gltf, scene, clip, mixer, action, skin, time: 0 };
  return {
    clips: gltf.animations.map((c) => ({ name: c.name, duration: c.duration, tracks: c.tracks.length })),
    clip: clip.name, duration: clip.duration, tracks: clip.tracks.map((t) => t.name), boundTracks: bound,
    skin: { name: skin.name, vertices: skin.geometry.attributes.position.count,
      morphTargets: (skin.morphTargetInfluences || []).length, morphTargetsRelative: skin.geometry.morphTargetsRelative,
      targetNames: Object.keys(skin.morphTargetDictionary || {}) },
    meshes, revision: THREE.REVISION,
  };
};

window.fhSample = (times, vertexIndices, withInfluences = true) => {
  // play forward from 0: one mixer.update(dt) per sample time, as a render loop would
  const { mixer, skin, action } = state;
  action.reset(); // a LoopOnce action that reached its end stays paused until reset
  mixer.setTime(0);
  let now = 0;
  const influences = [], positions = [], mixerTimes = [], matrices = [];
  const v = new THREE.Vector3();
  for (const t of times) {
    if (t < now) throw new Error('sample times must increase');
    mixer.update(t - now);
    now = t;
    state.scene.updateMatrixWorld(true);   // bones too: a skinned mesh's getVertexPosition reads their matrices
    mixerTimes.push(state.action.time);
    if (withInfluences) influences.push(Array.from(skin.morphTargetInfluences));
    positions.push(vertexIndices.map((i) => skin.localToWorld(skin.getVertexPosition(i, v)).toArray()));
    matrices.push(skin.matrixWorld.toArray());  // column-major, as glTF and three.js store it
  }
  return { influences, positions, actionTimes: mixerTimes, matrices };
};

window.fhSampleMeshes = (times) => {
  // every vertex of every mesh in world space at each time (morph targets and skinning applied by three.js on
  // the CPU, then matrixWorld), played forward from 0 as a render loop would; one entry per three.js Mesh with
  // the glTF mesh and primitive it was made from
  const { gltf, mixer, action } = state;
  action.reset();
  mixer.setTime(0);
  const meshes = [];
  gltf.scene.traverse((o) => {
    if (!o.isMesh) return;
    const ref = gltf.parser.associations.get(o) || {};
    meshes.push({ object: o, mesh: ref.meshes, primitive: ref.primitives ?? 0, name: o.name, positions: [] });
  });
  const v = new THREE.Vector3();
  let now = 0;
  for (const t of times) {
    if (t < now) throw new Error('sample times must increase');
    mixer.update(t - now);
    now = t;
    gltf.scene.updateMatrixWorld(true);
    for (const m of meshes) {
      const count = m.object.geometry.attributes.position.count;
      const out = new Array(count * 3);
      for (let i = 0; i < count; i++) {
        m.object.localToWorld(m.object.getVertexPosition(i, v));
        out[3 * i] = v.x; out[3 * i + 1] = v.y; out[3 * i + 2] = v.z;
      }
      m.positions.push(out);
    }
  }
  return meshes.map(({ mesh, primitive, name, positions }) => ({ mesh, primitive, name, positions }));
};

window.fhRender = (t, width, height, focus) => {
  // three panels: front, three-quarter (yaw 0.6 rad), and a close-up of the mouth around `focus` (world xyz)
  const { scene, mixer, skin, action } = state;
  action.reset();
  mixer.setTime(t);
  if (!state.renderer) {
    state.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    state.renderer.setSize(width, height);
    document.body.appendChild(state.renderer.domElement);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 1.2));
    const key = new THREE.DirectionalLight(0xffffff, 2.0);
    key.position.set(0.3, 0.4, 1.0);
    scene.add(key);
    scene.background = new THREE.Color(0x303030);
  }
  const renderer = state.renderer;
  const box = new THREE.Box3().setFromObject(skin);
  const centre = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length();
  const mouth = new THREE.Vector3(...focus);
  const panel = width / 3;
  const views = [[0, centre, size * 1.6], [0.6, centre, size * 1.6], [0.25, mouth, size * 0.45]];
  renderer.setScissorTest(true);
  views.forEach(([yaw, target, d], k) => {
    const camera = new THREE.PerspectiveCamera(25, panel / height, 0.005, 10);
    camera.position.set(target.x + d * Math.sin(yaw), target.y, target.z + d * Math.cos(yaw));
    camera.lookAt(target);
    renderer.setViewport(k * panel, 0, panel, height);
    renderer.setScissor(k * panel, 0, panel, height);
    renderer.render(scene, camera);
  });
  const gl = renderer.getContext();
  const debug = gl.getExtension('WEBGL_debug_renderer_info');
  return { renderer: gl.getParameter(debug ? debug.UNMASKED_RENDERER_WEBGL : gl.RENDERER), time: action.time };
};

window.fhRenderViews = (t, width, height, views) => {
  // side-by-side panels, each {yaw (rad, 0 = front), pitch (rad), target: world xyz, distance, fov (deg)}
  const { scene, mixer, action } = state;
  action.reset();
  mixer.setTime(t);
  if (!state.renderer) window.fhRender(t, width, height, [0, 0, 0]);
  const renderer = state.renderer;
  renderer.setSize(width, height);
  scene.background = new THREE.Color(0xd8d8d8);   // light: the painted brows are the darkest pixels
  const panel = width / views.length;
  renderer.setScissorTest(true);
  views.forEach((view, k) => {
    const camera = new THREE.PerspectiveCamera(view.fov || 20, panel / height, 0.005, 10);
    const [x, y, z] = view.target;
    const d = view.distance, yaw = view.yaw || 0, pitch = view.pitch || 0;
    camera.position.set(x + d * Math.sin(yaw) * Math.cos(pitch), y + d * Math.sin(pitch),
      z + d * Math.cos(yaw) * Math.cos(pitch));
    camera.lookAt(new THREE.Vector3(x, y, z));
    renderer.setViewport(k * panel, 0, panel, height);
    renderer.setScissor(k * panel, 0, panel, height);
    renderer.render(scene, camera);
  });
  return { time: action.time };
};

window.fhReady = true;
