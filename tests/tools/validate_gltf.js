// Validate a .glb or .gltf with the Khronos glTF-Validator; prints its JSON report.
// Usage: node validate_gltf.js FILE
const fs = require("fs");
const path = require("path");
const validator = require("gltf-validator");

const file = process.argv[2];
const data = new Uint8Array(fs.readFileSync(file));
validator.validateBytes(data, {
    uri: path.basename(file),
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
                    (error, bytes) => error ? reject(error.toString()) : resolve(new Uint8Array(bytes)));
    }),
}).then((report) => console.log(JSON.stringify(report)))
  .catch((error) => { console.error(error); process.exit(1); });
