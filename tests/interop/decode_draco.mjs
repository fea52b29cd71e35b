// SPDX-License-Identifier: MIT
// Decode a Draco-compressed glTF into plain accessors, as an importer that supports
// KHR_draco_mesh_compression sees it (Debian's Blender is built without Draco; the official
// builds decode it on import). glTF-Transform reads every extension it knows with the Draco
// decoder and writes the asset back without the compression; nothing else changes.
//
//   node decode_draco.mjs IN.glb OUT.glb
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import draco3d from 'draco3dgltf';

const [input, output] = process.argv.slice(2);
if (!input || !output) {
    console.error('usage: node decode_draco.mjs IN.glb OUT.glb');
    process.exit(2);
}
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
    'draco3d.decoder': await draco3d.createDecoderModule(),
});
const document = await io.read(input);
for (const extension of document.getRoot().listExtensionsUsed()) {
    if (extension.extensionName === 'KHR_draco_mesh_compression') {
        extension.dispose();
    }
}
await io.write(output, document);
