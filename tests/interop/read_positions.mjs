// SPDX-License-Identifier: MIT
// An independent glTF reader for the interop tests (tests/interop/interop_support.cpp):
// glTF-Transform with every extension it knows and the Draco and meshopt decoders, so nothing of
// meshmark's own reader is involved.
//
//   node read_positions.mjs IN.glb OUT.bin
//
// Writes every POSITION element of every TRIANGLES (4) and POINTS (0) primitive reached from the
// default scene (every scene when there is none), in world space (the node's world matrix applied,
// normalized integers dequantized by Accessor.getElement), as little-endian float64 x, y, z
// triples to OUT.bin: primitive after primitive in scene order (depth first), elements in
// accessor order. Prints a JSON summary on stdout: {vertices, primitives, min, max}.
import { writeFileSync } from 'node:fs';
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import draco3d from 'draco3dgltf';
import { MeshoptDecoder } from 'meshoptimizer';

const [input, output] = process.argv.slice(2);
if (!input || !output) {
    console.error('usage: node read_positions.mjs IN.glb OUT.bin');
    process.exit(2);
}

await MeshoptDecoder.ready;
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
    'draco3d.decoder': await draco3d.createDecoderModule(),
    'meshopt.decoder': MeshoptDecoder,
});
const document = await io.read(input);
const root = document.getRoot();
const defaultScene = root.getDefaultScene();
const scenes = defaultScene ? [defaultScene] : root.listScenes();

const TRIANGLES = 4;
const POINTS = 0;
const values = [];
let primitives = 0;
const min = [Infinity, Infinity, Infinity];
const max = [-Infinity, -Infinity, -Infinity];
const element = [0, 0, 0];

for (const scene of scenes) {
    // Scene.traverse visits every node below the scene's roots, parents first.
    scene.traverse((node) => {
        const mesh = node.getMesh();
        if (!mesh) {
            return;
        }
        const m = node.getWorldMatrix(); // column-major 4x4
        for (const primitive of mesh.listPrimitives()) {
            const mode = primitive.getMode();
            const position = primitive.getAttribute('POSITION');
            if ((mode !== TRIANGLES && mode !== POINTS) || !position) {
                continue;
            }
            primitives += 1;
            for (let i = 0; i < position.getCount(); i++) {
                position.getElement(i, element);
                const [x, y, z] = element;
                const world = [
                    m[0] * x + m[4] * y + m[8] * z + m[12],
                    m[1] * x + m[5] * y + m[9] * z + m[13],
                    m[2] * x + m[6] * y + m[10] * z + m[14],
                ];
                for (let a = 0; a < 3; a++) {
                    values.push(world[a]);
                    min[a] = Math.min(min[a], world[a]);
                    max[a] = Math.max(max[a], world[a]);
                }
            }
        }
    });
}

writeFileSync(output, new Uint8Array(new Float64Array(values).buffer));
console.log(JSON.stringify({ vertices: values.length / 3, primitives, min, max }));
