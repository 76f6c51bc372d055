// Validate glTF/GLB files with the Khronos glTF validator and print one JSON report per line:
// {"file": ..., "errors": N, "warnings": N, "messages": [...]}. Exit code 0 unless a file could not be read.
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
  const data = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource not allowed: ${uri}`)),
  });
  const issues = report.issues;
  return {
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    messages: issues.messages.map((m) => `${m.severity === 0 ? 'ERROR' : m.severity === 1 ? 'WARNING' : 'INFO'} ${m.code} ${m.pointer || ''}: ${m.message}`),
  };
}

(async () => {
  let failed = false;
  for (const file of process.argv.slice(2)) {
    try {
      console.log(JSON.stringify(await validate(file)));
    } catch (error) {
      failed = true;
      console.log(JSON.stringify({ file, errors: -1, warnings: 0, messages: [String(error)] }));
    }
  }
  process.exit(failed ? 1 : 0);
})();
