// Manual cross-check (not part of the build or tests): reads MCAP files hazmap wrote with the
// MCAP reference reader. In a scratch folder: npm install @mcap/core@2.2.2 @foxglove/wasm-zstd
// @foxglove/wasm-lz4, copy this file there, then: node mcap-reference-check.mjs FILE.mcap...
// Cross-check: hazmap-written MCAPs through the reference reader (@mcap/core McapIndexedReader
// and McapStreamReader).
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "@foxglove/wasm-lz4";
import fs from "node:fs";
await zstd.isLoaded; await lz4.isLoaded;
const decompressHandlers = {
  zstd: (buf, size) => zstd.decompress(buf, Number(size)),
  lz4: (buf, size) => lz4(buf, Number(size)),
};
for (const path of process.argv.slice(2)) {
  const bytes = fs.readFileSync(path);
  const readable = { size: async () => BigInt(bytes.length), read: async (off, len) => bytes.subarray(Number(off), Number(off + len)) };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const counts = {};
  let last = 0n, n = 0;
  for await (const m of reader.readMessages()) {
    const topic = reader.channelsById.get(m.channelId).topic;
    counts[topic] = (counts[topic] ?? 0) + 1; n++;
    if (m.logTime < last) throw new Error("out of order"); last = m.logTime;
  }
  const stats = reader.statistics;
  // Stream reader too (validates CRCs of chunks as it goes).
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(bytes);
  let recs = 0, msgs = 0, rec;
  while ((rec = stream.nextRecord())) { recs++; if (rec.type === "Message") msgs++; }
  console.log(path, JSON.stringify(counts), "indexed:", n, "stats:", stats.messageCount, "chunks:", stats.chunkCount,
              "chunkIndexes:", reader.chunkIndexes.length, "stream messages:", msgs, "done:", stream.done());
}
