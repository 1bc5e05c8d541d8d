// Lossless EXT_meshopt_compression of a .gltf: every bufferView is compressed as it is (no quantization, no
// filter, no reordering) into buffer 0; the original views keep their offsets into a fallback buffer without
// data (buffer 1). Index views holding one accessor use TRIANGLES (mode-4 primitives) or INDICES; other views
// ATTRIBUTES with their byteStride (or 4). Views that fit no mode (1-byte indices) are copied into buffer 0 as
// plain views. Usage: node meshopt_lossless.mjs IN.gltf OUT.(glb|gltf) [KHR] [INDICES]
import fs from 'fs';
import path from 'path';
import { MeshoptEncoder } from 'meshoptimizer';
await MeshoptEncoder.ready;
const [input, output, ...flags] = process.argv.slice(2);  // flags: KHR (KHR_meshopt_compression), INDICES (no TRIANGLES mode)
const ext = flags.includes('KHR') ? 'KHR_meshopt_compression' : 'EXT_meshopt_compression';
const g = JSON.parse(fs.readFileSync(input, 'utf8'));
const buffers = g.buffers.map((b) => b.uri.startsWith('data:') ? Buffer.from(b.uri.split(',')[1], 'base64')
                                                              : fs.readFileSync(path.join(path.dirname(input), b.uri)));
if (buffers.length !== 1) throw new Error('one buffer expected');
const indexUse = new Map();  // view -> {accessors, triangles}
for (const m of g.meshes) for (const p of m.primitives) if (p.indices !== undefined) {
  const a = g.accessors[p.indices];
  const u = indexUse.get(a.bufferView) || { accessors: new Set(), triangles: true };
  u.accessors.add(p.indices);
  if ((p.mode ?? 4) !== 4) u.triangles = false;
  indexUse.set(a.bufferView, u);
}
const chunks = [];
let offset = 0;
const push = (bytes) => { const at = offset; chunks.push(Buffer.from(bytes)); offset += bytes.length;
  const pad = (4 - offset % 4) % 4; if (pad) { chunks.push(Buffer.alloc(pad)); offset += pad; } return at; };
const modes = {};
g.bufferViews.forEach((v, i) => {
  const data = buffers[v.buffer].subarray(v.byteOffset || 0, (v.byteOffset || 0) + v.byteLength);
  const use = indexUse.get(i);
  let mode, stride;
  if (use) {
    const a = g.accessors[[...use.accessors][0]];
    stride = a.componentType === 5125 ? 4 : a.componentType === 5123 ? 2 : 1;
    mode = !flags.includes('INDICES') && use.accessors.size === 1 && use.triangles && (v.byteLength / stride) % 3 === 0 ? 'TRIANGLES' : 'INDICES';
    if (stride === 1) mode = undefined;
  } else {
    stride = v.byteStride || 4;
    mode = v.byteLength % stride === 0 ? 'ATTRIBUTES' : undefined;
  }
  if (!mode) {  // plain copy into buffer 0
    v.buffer = 0; v.byteOffset = push(data); modes.PLAIN = (modes.PLAIN || 0) + 1; return;
  }
  const count = v.byteLength / stride;
  const encoded = MeshoptEncoder.encodeGltfBuffer(new Uint8Array(data), count, stride, mode);
  const at = push(encoded);
  v.buffer = 1;
  v.extensions = { [ext]: { buffer: 0, byteOffset: at, byteLength: encoded.length, byteStride: stride, mode, count } };
  modes[mode] = (modes[mode] || 0) + 1;
});
const bin = Buffer.concat(chunks);
const fallback = { byteLength: buffers[0].length, extensions: { [ext]: { fallback: true } } };
g.extensionsUsed = [...new Set([...(g.extensionsUsed || []), ext])];
g.extensionsRequired = [...new Set([...(g.extensionsRequired || []), ext])];
if (output.endsWith('.glb')) {
  g.buffers = [{ byteLength: bin.length }, fallback];
  let json = Buffer.from(JSON.stringify(g));
  json = Buffer.concat([json, Buffer.alloc((4 - json.length % 4) % 4, 0x20)]);
  const header = Buffer.alloc(12), jh = Buffer.alloc(8), bh = Buffer.alloc(8);
  header.writeUInt32LE(0x46546c67, 0); header.writeUInt32LE(2, 4); header.writeUInt32LE(12 + 8 + json.length + 8 + bin.length, 8);
  jh.writeUInt32LE(json.length, 0); jh.writeUInt32LE(0x4e4f534a, 4); bh.writeUInt32LE(bin.length, 0); bh.writeUInt32LE(0x004e4942, 4);
  fs.writeFileSync(output, Buffer.concat([header, jh, json, bh, bin]));
} else {
  const binName = path.basename(output).replace(/\.gltf$/, '.bin');
  g.buffers = [{ byteLength: bin.length, uri: binName }, { byteLength: buffers[0].length }];  // untagged fallback
  fs.writeFileSync(path.join(path.dirname(output), binName), bin);
  fs.writeFileSync(output, JSON.stringify(g));
}
console.log(output, bin.length, 'bytes of compressed data;', JSON.stringify(modes));
