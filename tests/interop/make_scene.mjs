// A multi-part game-style asset from three single-mesh glTF files, for the interop tests:
// node "body" (first mesh, with an embedded PNG base-colour texture) under a rotation, its child
// "part" (second mesh, scaled and moved), and the third mesh instanced by two nodes
// ("bunny_a", "bunny_b": one mesh, two transforms).
// Usage: node make_scene.mjs FIRST.glb SECOND.glb THIRD.glb OUT.glb
import { NodeIO, Document } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import zlib from 'node:zlib';

const io = new NodeIO().registerExtensions(ALL_EXTENSIONS);
const [firstPath, secondPath, thirdPath, outPath] = process.argv.slice(2);
const doc = new Document();
const buffer = doc.createBuffer();

// The first primitive of a file, copied (attributes and indices) into this document.
async function primitiveOf(path) {
  const source = (await io.read(path)).getRoot().listMeshes()[0].listPrimitives()[0];
  const copy = (a) => doc.createAccessor().setType(a.getType()).setArray(a.getArray().slice())
    .setNormalized(a.getNormalized()).setBuffer(buffer);
  const primitive = doc.createPrimitive();
  for (const semantic of source.listSemantics()) {
    primitive.setAttribute(semantic, copy(source.getAttribute(semantic)));
  }
  if (source.getIndices()) primitive.setIndices(copy(source.getIndices()));
  return primitive;
}

// A valid 4x4 RGBA PNG (a checker), made here so that no binary fixture is committed.
function checkerPng() {
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc = (bytes) => {
    let c = 0xffffffff;
    for (const b of bytes) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
    return (c ^ 0xffffffff) >>> 0;
  };
  const chunk = (type, data) => {
    const body = Buffer.concat([Buffer.from(type, 'ascii'), data]);
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0);
    body.copy(out, 4);
    out.writeUInt32BE(crc(body), 8 + data.length);
    return out;
  };
  const header = Buffer.alloc(13);
  header.writeUInt32BE(4, 0);
  header.writeUInt32BE(4, 4);
  header[8] = 8;  // bit depth
  header[9] = 6;  // RGBA
  const rows = [];
  for (let y = 0; y < 4; ++y) {
    rows.push(0);  // filter: none
    for (let x = 0; x < 4; ++x) rows.push(...((x + y) % 2 ? [200, 40, 40, 255] : [240, 240, 240, 255]));
  }
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', header),
    chunk('IDAT', zlib.deflateSync(Buffer.from(rows))), chunk('IEND', Buffer.alloc(0))]);
}

const texture = doc.createTexture('checker').setImage(new Uint8Array(checkerPng())).setMimeType('image/png');
const painted = doc.createMaterial('painted').setBaseColorTexture(texture);
const first = doc.createMesh('first').addPrimitive((await primitiveOf(firstPath)).setMaterial(painted));
const second = doc.createMesh('second').addPrimitive(await primitiveOf(secondPath));
const third = doc.createMesh('third').addPrimitive(await primitiveOf(thirdPath));
const body = doc.createNode('body').setMesh(first).setTranslation([1, 0, 0])
  .setRotation([0, Math.sin(0.2), 0, Math.cos(0.2)]);
body.addChild(doc.createNode('part').setMesh(second).setScale([0.08, 0.08, 0.08]).setTranslation([0, 1.2, 0]));
const scene = doc.createScene('scene').addChild(body)
  .addChild(doc.createNode('bunny_a').setMesh(third).setTranslation([-1.5, 0, 0]).setScale([6, 6, 6]))
  .addChild(doc.createNode('bunny_b').setMesh(third).setTranslation([-1.5, 0, 1.5]).setScale([6, 6, 6]));
doc.getRoot().setDefaultScene(scene);
await io.write(outPath, doc);
