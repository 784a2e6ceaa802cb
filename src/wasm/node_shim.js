// --extern-pre-js for the ES6 module: under Node, emscripten 3.1.6's loader reads `__dirname` and
// `require`, which an ES module does not have. Browsers skip this (no process.versions.node), and
// the import is hidden from bundlers, which would otherwise try to resolve Node's 'module'.
var __ikchainNodeModule = 'mod' + 'ule';
var require = (typeof process === 'object' && process.versions && process.versions.node)
  ? (await import(/* @vite-ignore */ __ikchainNodeModule)).createRequire(import.meta.url) : undefined;
var __dirname = require ? require('path').dirname(new URL(import.meta.url).pathname) : '/';
