// The package's main entry (`@meshstream/web`, docs/design/web.md, "The npm
// package"): the three.js plugin and the plain-JS API. `@meshstream/web/plugin`
// and `@meshstream/web/client` are the same, one at a time (the client alone
// needs no three.js).
export { MeshstreamProgressive, viewOfCamera } from './plugin.js';
export { DecoderWorker, MeshstreamClient, fetchPrefix, jobSpec } from './client.js';
