// Validate glTF files with the Khronos glTF-Validator (npm `gltf-validator`, installed
// into .tools/node_modules by `bash scripts/setup.sh --browser`).
//
//   node scripts/gltf_validate.mjs FILE.glb|FILE.gltf ...
//
// Prints one JSON object: {"validator": VERSION, "reports": {FILE: REPORT, ...}}, each
// REPORT the validator's own (issues.numErrors, numWarnings, numInfos, messages).
// A .gltf's external buffers are read from beside it. Exit 0 when every file was
// validated (whatever the reports say), 1 when one could not be read or parsed at all,
// 2 for no argument, 3 when the package is not installed (the fix on stderr).
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(import.meta.url);

let validator;
try {
  validator = require(require.resolve("gltf-validator", { paths: [path.join(here, "..", ".tools")] }));
} catch {
  console.error("gltf_validate: the npm package gltf-validator is not installed: run `bash scripts/setup.sh --browser`");
  process.exit(3);
}

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node scripts/gltf_validate.mjs FILE.glb|FILE.gltf ...");
  process.exit(2);
}

const reports = {};
let failed = false;
for (const file of files) {
  try {
    const bytes = new Uint8Array(await readFile(file));
    reports[file] = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0, // every issue
      writeTimestamp: false,
      externalResourceFunction: (uri) =>
        readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((data) => new Uint8Array(data)),
    });
  } catch (error) {
    console.error(`gltf_validate: ${file}: ${error}`);
    failed = true;
  }
}
console.log(JSON.stringify({ validator: validator.version(), reports }));
process.exit(failed ? 1 : 0);
