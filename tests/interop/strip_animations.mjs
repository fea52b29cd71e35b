// SPDX-License-Identifier: MIT
// Drop every animation of a glTF asset (its skins, joints and scene pose stay), as an artist
// exports a rigged character without its clips. glTF-Transform reads and writes it; the
// animations' samplers go with them, and the accessors of their keys and times.
//
//   node strip_animations.mjs IN.glb OUT.glb
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import { prune } from '@gltf-transform/functions';

const [input, output] = process.argv.slice(2);
if (!input || !output) {
    console.error('usage: node strip_animations.mjs IN.glb OUT.glb');
    process.exit(2);
}
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS);
const document = await io.read(input);
for (const animation of document.getRoot().listAnimations()) {
    animation.dispose();
}
await document.transform(prune({ propertyTypes: ['Accessor'] }));  // the keys and times only
await io.write(output, document);
