// SPDX-License-Identifier: MIT
// The Khronos glTF validator for the interop tests (tests/interop/interop_support.cpp).
//
//   node validate.mjs IN.glb
//
// Prints {errors, warnings, infos, hints, codes: {CODE: count, ...}, messages: [first 20]} as
// JSON on stdout. External resources (buffers, images) are resolved from the file's folder.
import { readFile } from 'node:fs/promises';
import { basename, dirname, resolve } from 'node:path';
import validator from 'gltf-validator';

const [input] = process.argv.slice(2);
if (!input) {
    console.error('usage: node validate.mjs IN.glb');
    process.exit(2);
}

const folder = dirname(resolve(input));
const report = await validator.validateBytes(new Uint8Array(await readFile(input)), {
    uri: basename(input),
    maxIssues: 0, // no limit
    externalResourceFunction: async (uri) => new Uint8Array(await readFile(resolve(folder, decodeURIComponent(uri)))),
});
const codes = {};
for (const message of report.issues.messages) {
    codes[message.code] = (codes[message.code] ?? 0) + 1;
}
console.log(JSON.stringify({
    errors: report.issues.numErrors,
    warnings: report.issues.numWarnings,
    infos: report.issues.numInfos,
    hints: report.issues.numHints,
    codes,
    messages: report.issues.messages.slice(0, 20).map((m) => `${m.code} ${m.pointer ?? ''}: ${m.message}`),
}));
