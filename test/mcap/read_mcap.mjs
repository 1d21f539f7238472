// Reads an MCAP file with the reference TypeScript reader (@mcap/core) and
// prints what it found as JSON, for test_mcap to check saccade's writer:
//   node read_mcap.mjs FILE
// Summary-driven (McapIndexedReader: schemas, channels, statistics, chunk
// indexes, every message through the message indexes) and a linear stream
// read (McapStreamReader, every CRC validated). Exits 1 with the reader's
// error on stderr when either refuses the file.
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "@foxglove/wasm-lz4";
import { open, readFile } from "node:fs/promises";

const path = process.argv[2];
await zstd.isLoaded;
await lz4.isLoaded;
const decompressHandlers = {
  zstd: (buffer, size) => zstd.decompress(buffer, Number(size)),
  lz4: (buffer, size) => lz4(buffer, Number(size)),
};

try {
  const handle = await open(path, "r");
  const { size } = await handle.stat();
  const readable = {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const buffer = new Uint8Array(Number(length));
      await handle.read(buffer, 0, Number(length), Number(offset));
      return buffer;
    },
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const counts = {};
  const firstLogTime = {};
  let previous = -1n;
  let ordered = true;
  for await (const message of reader.readMessages()) {
    const topic = reader.channelsById.get(message.channelId).topic;
    counts[topic] = (counts[topic] ?? 0) + 1;
    if (!(topic in firstLogTime)) firstLogTime[topic] = message.logTime.toString();
    if (message.logTime < previous) ordered = false;
    previous = message.logTime;
  }
  await handle.close();

  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(await readFile(path));
  let streamMessages = 0;
  let dataEnd = false;
  let footer = false;
  for (let record; (record = stream.nextRecord()); ) {
    if (record.type === "Message") streamMessages++;
    if (record.type === "DataEnd") dataEnd = true;
    if (record.type === "Footer") footer = true;
  }

  const stats = reader.statistics;
  console.log(
    JSON.stringify({
      profile: reader.header.profile,
      library: reader.header.library,
      schemas: [...reader.schemasById.values()].map((s) => ({
        id: s.id,
        name: s.name,
        encoding: s.encoding,
        bytes: s.data.length,
      })),
      channels: [...reader.channelsById.values()].map((c) => ({
        id: c.id,
        topic: c.topic,
        schemaId: c.schemaId,
        messageEncoding: c.messageEncoding,
        saccadeType: c.metadata.get("saccade_type") ?? "",
      })),
      chunks: reader.chunkIndexes.length,
      compression: [...new Set(reader.chunkIndexes.map((c) => c.compression))],
      statistics: stats
        ? {
            messageCount: Number(stats.messageCount),
            channelCount: stats.channelCount,
            schemaCount: stats.schemaCount,
            chunkCount: stats.chunkCount,
          }
        : null,
      counts,
      firstLogTime,
      logTimeOrdered: ordered,
      stream: { messages: streamMessages, dataEnd, footer, done: stream.done() },
    }),
  );
} catch (error) {
  console.error(`read_mcap: ${path}: ${error.message ?? error}`);
  process.exit(1);
}
