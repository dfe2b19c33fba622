// Reads a KTX 2.0 file with readers shlight did not write, for tests/live/reflections/test_ktx2.py:
// the npm package ktx-parse (Khronos container parser) and three.js's KTX2Loader
// (its raw-texture path, the one a browser app takes for RGBA16F). Prints JSON: the header,
// the data format descriptor, the key/value data (as text), and every level's bytes as
// base64, once per reader.
//   node ktx2_read.mjs FILE.ktx2
import { readFileSync } from "node:fs";
import { read } from "ktx-parse";
import { KTX2Loader } from "three/examples/jsm/loaders/KTX2Loader.js";

const bytes = new Uint8Array(readFileSync(process.argv[2]));
const b64 = (a) => Buffer.from(a.buffer, a.byteOffset, a.byteLength).toString("base64");
const text = (v) => (typeof v === "string" ? v : new TextDecoder().decode(v).replace(/\0$/, ""));

const c = read(bytes);
const dfd = c.dataFormatDescriptor[0];
const out = {
  ktxParse: {
    vkFormat: c.vkFormat, typeSize: c.typeSize, pixelWidth: c.pixelWidth,
    pixelHeight: c.pixelHeight, pixelDepth: c.pixelDepth, layerCount: c.layerCount,
    faceCount: c.faceCount, levelCount: c.levelCount,
    supercompressionScheme: c.supercompressionScheme,
    dfd: {
      colorModel: dfd.colorModel, colorPrimaries: dfd.colorPrimaries,
      transferFunction: dfd.transferFunction, flags: dfd.flags, bytesPlane: dfd.bytesPlane,
      samples: dfd.samples.map((s) => ({ bitOffset: s.bitOffset, bitLength: s.bitLength,
        channelType: s.channelType, lower: s.sampleLower, upper: s.sampleUpper })),
    },
    keyValue: Object.fromEntries(Object.entries(c.keyValue).map(([k, v]) => [k, text(v)])),
    levels: c.levels.map((l) => ({ bytes: b64(l.levelData),
      uncompressedByteLength: l.uncompressedByteLength })),
  },
};
const texture = await new KTX2Loader()._createTexture(bytes.slice().buffer);
out.three = {
  type: texture.type, format: texture.format, isCube: !!texture.isCubeTexture,
  mipmaps: texture.mipmaps.map((m) => ({ width: m.width, height: m.height, data: b64(m.data) })),
};
console.log(JSON.stringify(out));
