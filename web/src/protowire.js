// The protobuf wire format (varints, tags, length-delimited fields), enough
// for the session's messages (proto/meshstream/v1/stream.proto) over
// WebSocket (session.js). Safe on untrusted bytes: every read is checked
// against the end, and a malformed message throws an Error naming the offset.

export class ProtoReader {
  constructor(bytes, start = 0, end = bytes.byteLength) {
    this.b = bytes;
    this.pos = start;
    this.end = end;
  }

  done() {
    return this.pos >= this.end;
  }

  // An unsigned varint as a Number (exact to 2^53; larger values lose precision
  // only in fields we do not read as numbers).
  varint() {
    let v = 0;
    let scale = 1;
    for (let i = 0; i < 10; ++i) {
      if (this.pos >= this.end) throw new Error('protobuf: a varint runs past the end at ' + this.pos);
      const byte = this.b[this.pos++];
      v += (byte & 0x7f) * scale;
      scale *= 128;
      if ((byte & 0x80) === 0) return v;
    }
    throw new Error('protobuf: a varint longer than 10 bytes at ' + this.pos);
  }

  // The next field: { field, wire } or null at the end.
  tag() {
    if (this.done()) return null;
    const t = this.varint();
    const field = Math.floor(t / 8), wire = t % 8;
    if (field === 0) throw new Error('protobuf: field number 0 at ' + this.pos);
    return { field, wire };
  }

  bytes() {
    const n = this.varint();
    if (n > this.end - this.pos) throw new Error('protobuf: a field of ' + n + ' bytes runs past the end at ' + this.pos);
    const out = this.b.subarray(this.pos, this.pos + n);
    this.pos += n;
    return out;
  }

  string() {
    return new TextDecoder().decode(this.bytes());
  }

  skip(wire) {
    if (wire === 0) this.varint();
    else if (wire === 1) this.advance(8);
    else if (wire === 2) this.bytes();
    else if (wire === 5) this.advance(4);
    else throw new Error('protobuf: wire type ' + wire + ' at ' + this.pos);
  }

  advance(n) {
    if (n > this.end - this.pos) throw new Error('protobuf: a fixed field runs past the end at ' + this.pos);
    this.pos += n;
  }

  // Reads a message with `fields`: { number: (reader, wire) => void }; the
  // other fields are skipped.
  message(fields) {
    for (let t = this.tag(); t !== null; t = this.tag()) {
      const read = fields[t.field];
      if (read) read(this, t.wire);
      else this.skip(t.wire);
    }
  }

  sub() {
    const b = this.bytes();
    return new ProtoReader(b);
  }
}

export class ProtoWriter {
  constructor() {
    this.parts = [];
    this.length = 0;
  }

  raw(bytes) {
    this.parts.push(bytes);
    this.length += bytes.byteLength;
  }

  varint(v) {
    const out = [];
    let x = v;
    if (x < 0) throw new Error('protobuf: a negative varint');  // our fields are never negative
    do {
      let byte = x % 128;
      x = Math.floor(x / 128);
      if (x > 0) byte |= 0x80;
      out.push(byte);
    } while (x > 0);
    this.raw(Uint8Array.from(out));
  }

  tag(field, wire) {
    this.varint(field * 8 + wire);
  }

  uint(field, v) {
    if (v === undefined || v === null || v === 0) return;
    this.tag(field, 0);
    this.varint(v);
  }

  // int32/int64 with negative values as ten-byte two's complement.
  int(field, v) {
    if (v === undefined || v === null || v === 0) return;
    this.tag(field, 0);
    if (v >= 0) return this.varint(v);
    let x = BigInt.asUintN(64, BigInt(v));
    const out = [];
    for (let i = 0; i < 10; ++i) {
      let byte = Number(x & 0x7fn);
      x >>= 7n;
      if (x > 0n) byte |= 0x80;
      out.push(byte);
      if (x === 0n) break;
    }
    this.raw(Uint8Array.from(out));
  }

  bool(field, v) {
    if (v) this.uint(field, 1);
  }

  double(field, v) {
    this.tag(field, 1);
    const b = new Uint8Array(8);
    new DataView(b.buffer).setFloat64(0, v, true);
    this.raw(b);
  }

  // A packed repeated double: one length-delimited field of 8-byte values.
  doubles(field, values) {
    const b = new Uint8Array(8 * values.length);
    const view = new DataView(b.buffer);
    values.forEach((v, i) => view.setFloat64(8 * i, v, true));
    this.bytesField(field, b);
  }

  bytesField(field, bytes) {
    this.tag(field, 2);
    this.varint(bytes.byteLength);
    this.raw(bytes);
  }

  string(field, s) {
    if (!s) return;
    this.bytesField(field, new TextEncoder().encode(s));
  }

  message(field, writer) {
    this.bytesField(field, writer.finish());
  }

  finish() {
    const out = new Uint8Array(this.length);
    let at = 0;
    for (const p of this.parts) {
      out.set(p, at);
      at += p.byteLength;
    }
    return out;
  }
}
