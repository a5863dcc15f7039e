// SPDX-License-Identifier: GPL-3.0-or-later
// Khronos glTF-Validator (npm gltf-validator) on each GLB given; prints one JSON array on stdout:
// [{file, numErrors, numWarnings, numInfos, numHints, messages: [first 50], info}].
import { readFile } from 'node:fs/promises';
import { basename } from 'node:path';
import validator from 'gltf-validator';

const results = [];
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: basename(file),
    maxIssues: 0, // 0 = no limit on the number of reported issues
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri} not allowed`)),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  results.push({
    file, validatorVersion: report.validatorVersion, numErrors, numWarnings, numInfos, numHints,
    messages: messages.slice(0, 50), info: report.info,
  });
}
process.stdout.write(JSON.stringify(results) + '\n');
