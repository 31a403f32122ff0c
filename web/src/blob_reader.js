// A stream blob (docs/spec/progressive-format.md, section 2) read as its bytes
// arrive, for the file read by HTTP ranges: push() takes the next bytes
// and returns what they completed, in order:
//   { kind: 'header', bytes }                      the stream header
//   { kind: 'control', refinement, bytes }         a refinement's control block
//   { kind: 'datagram', refinement, bytes }        each of its datagrams
//   { kind: 'end', refinement, datagrams }         its datagrams are all there
// The views returned stay valid (they are copies of the blob's bytes).
// Throws an Error naming the byte offset on a malformed blob: a bad magic or
// version, a varint over 10 bytes, a block longer than `maxBlock`, more than
// 255 refinements, or bytes after the last refinement.

const MAGIC = [0x4d, 0x53, 0x50, 0x53];

export class BlobReader {
  constructor({ maxBlock = 64 << 20 } = {}) {
    this.maxBlock = maxBlock;
    this.buf = new Uint8Array(0);
    this.pos = 0;        // read position in buf
    this.offset = 0;     // blob offset of buf[0]
    this.state = 'magic';
    this.refinements = -1;
    this.refinement = 0;
    this.left = 0;       // datagrams left in the current refinement
    this.done = false;
  }

  // Bytes of the blob read so far.
  get consumed() {
    return this.offset + this.pos;
  }

  push(chunk) {
    if (this.done && chunk.byteLength > 0) throw new Error('stream blob: bytes after the last refinement at ' + this.consumed);
    const rest = this.buf.subarray(this.pos);
    const next = new Uint8Array(rest.byteLength + chunk.byteLength);
    next.set(rest, 0);
    next.set(chunk, rest.byteLength);
    this.offset += this.pos;
    this.buf = next;
    this.pos = 0;
    const out = [];
    for (;;) {
      const event = this.step();
      if (event === null) break;
      if (event !== undefined) out.push(event);
      if (this.done) {
        if (this.pos < this.buf.byteLength) throw new Error('stream blob: bytes after the last refinement at ' + this.consumed);
        break;
      }
    }
    return out;
  }

  // One element, or null when the bytes run out (undefined: read, nothing to say).
  step() {
    switch (this.state) {
      case 'magic': {
        if (this.buf.byteLength - this.pos < 5) return null;
        for (let i = 0; i < 4; ++i) {
          if (this.buf[this.pos + i] !== MAGIC[i]) throw new Error('stream blob: bad magic at 0');
        }
        const version = this.buf[this.pos + 4];
        if (version < 1 || version > 4) throw new Error('stream blob: version ' + version + ' at 4');
        this.pos += 5;
        this.state = 'header';
        return undefined;
      }
      case 'header': {
        const b = this.block();
        if (b === null) return null;
        this.state = 'count';
        return { kind: 'header', bytes: b };
      }
      case 'count': {
        const v = this.varint();
        if (v === null) return null;
        if (v > 255) throw new Error('stream blob: ' + v + ' refinements (at most 255) at ' + this.consumed);
        this.refinements = v;
        this.state = v === 0 ? 'done' : 'control';
        if (v === 0) this.done = true;
        return undefined;
      }
      case 'control': {
        const b = this.block();
        if (b === null) return null;
        this.state = 'datagrams';
        return { kind: 'control', refinement: this.refinement, bytes: b };
      }
      case 'datagrams': {
        const v = this.varint();
        if (v === null) return null;
        if (v > 1 << 20) throw new Error('stream blob: ' + v + ' datagrams in refinement ' + this.refinement + ' at ' + this.consumed);
        this.left = v;
        this.total = v;
        this.state = 'datagram';
        return undefined;
      }
      case 'datagram': {
        if (this.left === 0) {
          const event = { kind: 'end', refinement: this.refinement, datagrams: this.total };
          ++this.refinement;
          if (this.refinement === this.refinements) {
            this.state = 'done';
            this.done = true;
          } else {
            this.state = 'control';
          }
          return event;
        }
        const b = this.block();
        if (b === null) return null;
        --this.left;
        return { kind: 'datagram', refinement: this.refinement, bytes: b };
      }
      default:
        return null;
    }
  }

  // An unsigned LEB128 at pos, or null when incomplete (pos unchanged).
  varint() {
    let v = 0;
    let scale = 1;
    for (let i = 0; i < 10; ++i) {
      if (this.pos + i >= this.buf.byteLength) return null;
      const byte = this.buf[this.pos + i];
      v += (byte & 0x7f) * scale;
      scale *= 128;
      if ((byte & 0x80) === 0) {
        if (!Number.isSafeInteger(v)) throw new Error('stream blob: varint out of range at ' + this.consumed);
        this.pos += i + 1;
        return v;
      }
    }
    throw new Error('stream blob: varint longer than 10 bytes at ' + this.consumed);
  }

  // A block (varint length, then the bytes) copied out, or null when incomplete.
  block() {
    const start = this.pos;
    const n = this.varint();
    if (n === null) return null;
    if (n > this.maxBlock) throw new Error('stream blob: a block of ' + n + ' bytes at ' + (this.offset + start));
    if (this.buf.byteLength - this.pos < n) {
      this.pos = start;
      return null;
    }
    const b = this.buf.slice(this.pos, this.pos + n);
    this.pos += n;
    return b;
  }
}
