// Print the Khronos glTF-Validator report of a GLB (scripts/gltf_check/run.sh installs the package).
const fs = require('fs');
const validator = require('gltf-validator');
const path = process.argv[2];
const data = new Uint8Array(fs.readFileSync(path));
validator.validateBytes(data).then((report) => {
  const i = report.issues;
  console.log(JSON.stringify({validator: report.validatorVersion, errors: i.numErrors, warnings: i.numWarnings,
     infos: i.numInfos, hints: i.numHints, messages: i.messages.slice(0, 12).map(m => [m.severity, m.code, m.message, m.pointer]),
     info: {animations: report.info.animationCount, skins: report.info.skinCount, morph: report.info.hasMorphTargets, nodes: report.info.nodeCount}}, null, 1));
}).catch((e) => { console.error('failed', e); process.exit(2); });
