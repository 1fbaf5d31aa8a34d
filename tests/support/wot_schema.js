// Validates Thing Descriptions and Thing Models against the W3C JSON schemas node-wot ships
// (wot-thing-description-types' td-json-schema-validation.json, wot-thing-model-types'
// tm-json-schema-validation.json), with Ajv as node-wot itself compiles them (strict: false, ajv-formats).
// Run with NODE_PATH at the cached node-wot install (tests/support/node_engines.py).
//
//   node wot_schema.js FILE.json...
//
// A document whose @type holds tm:ThingModel is checked against the TM schema, every other one against the
// TD schema. Prints one JSON line: {FILE: [] (valid) or [error, ...]}.
"use strict";

const fs = require("fs");
const Ajv = require("ajv");
const addFormats = require("ajv-formats");

const ajv = new Ajv({ strict: false, logger: false });
addFormats(ajv);
const td = ajv.compile(require("wot-thing-description-types/schema/td-json-schema-validation.json"));
const tm = ajv.compile(require("wot-thing-model-types/schema/tm-json-schema-validation.json"));

function isModel(doc) {
    const type = doc["@type"];
    return type === "tm:ThingModel" || (Array.isArray(type) && type.includes("tm:ThingModel"));
}

const out = {};
for (const file of process.argv.slice(2)) {
    const doc = JSON.parse(fs.readFileSync(file, "utf8"));
    const validate = isModel(doc) ? tm : td;
    out[file] = validate(doc)
        ? []
        : validate.errors.map((e) => `${e.instancePath || "/"} ${e.message} ${JSON.stringify(e.params)}`);
}
process.stdout.write(JSON.stringify(out) + "\n");
