// CDR decoded with `@foxglove/cdr`'s CdrReader, walking a ros2msg definition text (as a
// Foxglove channel or service advertises it) parsed with `@lichtblick/rosmsg`.
import cdr from "@foxglove/cdr";
import rosmsg from "@lichtblick/rosmsg";

const { CdrReader } = cdr; // (CommonJS packages: named exports via the default)
const { parse } = rosmsg;

const PRIMITIVE = {
  bool: (r) => r.uint8() !== 0, int8: (r) => r.int8(), uint8: (r) => r.uint8(), byte: (r) => r.uint8(),
  char: (r) => r.uint8(), int16: (r) => r.int16(), uint16: (r) => r.uint16(), int32: (r) => r.int32(),
  uint32: (r) => r.uint32(), int64: (r) => Number(r.int64()), uint64: (r) => Number(r.uint64()),
  float32: (r) => r.float32(), float64: (r) => r.float64(), string: (r) => r.string(),
  // rosmsg parses builtin_interfaces/Time and Duration into these
  time: (r) => ({ sec: r.int32(), nanosec: r.uint32() }),
  duration: (r) => ({ sec: r.int32(), nanosec: r.uint32() }),
};

// Decodes `data` (CDR with its 4-byte header) as the first type of a ros2msg definition text.
export function decodeCdr(schema, data) {
  const definitions = parse(schema, { ros2: true });
  const byName = new Map(definitions.map((d) => [d.name, d]));
  const reader = new CdrReader(data);
  const readStruct = (definition) => {
    const out = {};
    const fields = definition.definitions.filter((f) => !f.isConstant);
    if (fields.length === 0) reader.uint8(); // ROS 2's placeholder byte of an empty message
    for (const field of fields) {
      const one = field.isComplex ? () => readStruct(byName.get(field.type)) : () => PRIMITIVE[field.type](reader);
      if (field.isArray) {
        const count = field.arrayLength ?? reader.sequenceLength();
        out[field.name] = Array.from({ length: count }, one);
      } else {
        out[field.name] = one();
      }
    }
    return out;
  };
  return readStruct(definitions[0]);
}
