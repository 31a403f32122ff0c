// Declarations of src/index.js: the plugin's and the client's, as one entry.
export * from './plugin.js';
export * from './client.js';
