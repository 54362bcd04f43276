"""Read every channel of an ik-pipeline archive with only `mcap` and `protobuf` (no `import pipeline`).

The schemas are in the file; this is the snippet docs/archives.md shows. Prints one JSON object: the
decoded messages per topic, with every repeated field as a list.
"""
import json
import sys

from google.protobuf import descriptor_pb2, message_factory
from mcap.reader import make_reader

out = {}
with open(sys.argv[1], "rb") as fh:
    reader = make_reader(fh)
    for schema, channel, message in reader.iter_messages():
        if schema.encoding == "protobuf":
            files = descriptor_pb2.FileDescriptorSet.FromString(schema.data).file
            cls = message_factory.GetMessages(list(files))[schema.name]
            msg = cls.FromString(message.data)
            fields = {f.name: v if isinstance(v, (str, bytes, int, float)) else list(v) for f, v in msg.ListFields()}
        else:  # JSON channels (a study's measurements)
            fields = json.loads(message.data)
        out.setdefault(channel.topic, []).append(fields)
    meta = {r.name: dict(r.metadata) for r in reader.iter_metadata()}
print(json.dumps({"metadata": meta, "messages": out, "pipeline_imported": "pipeline" in sys.modules},
                 default=lambda b: b.decode() if isinstance(b, bytes) else str(b)))
