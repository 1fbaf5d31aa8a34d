// node-wot consumes a Thing Description exported by `mdl export --to wot` and reads or writes its properties
// through its own Modbus binding (tests/engines/test_export_wot.py; run with NODE_PATH at the cached
// node-wot install, tests/support/node_engines.py).
//
//   node wot_client.js TD.json JOB.json
//
// JOB: {"write": {name: value, ...}, "read": [name, ...] or null (every property that can be read),
//       "observe": name, "for_ms": N (observe the property for N ms: the values its polls gave)}.
// Writes come first, one at a time, then reads, one at a time: node-wot merges concurrent reads of
// neighbouring coils into one request and then slices the reply wrongly for the second.
// Prints one JSON line: {"wrote": {name: true | {"error": text}}, "read": {name: value | {"error": text}},
// "observed": [value, ...]}.
"use strict";

const fs = require("fs");
const { Servient } = require("@node-wot/core");
const { ModbusClientFactory } = require("@node-wot/binding-modbus");

function message(err) {
    return String(err && err.message ? err.message : err);
}

async function main() {
    const td = JSON.parse(fs.readFileSync(process.argv[2], "utf8"));
    const job = JSON.parse(fs.readFileSync(process.argv[3], "utf8"));
    const servient = new Servient();
    servient.addClientFactory(new ModbusClientFactory());
    const WoT = await servient.start();
    const thing = await WoT.consume(td);
    const out = { wrote: {}, read: {} };
    for (const [name, value] of Object.entries(job.write || {})) {
        try {
            await thing.writeProperty(name, value);
            out.wrote[name] = true;
        } catch (err) {
            out.wrote[name] = { error: message(err) };
        }
    }
    const names = job.read || Object.keys(td.properties).filter((name) => !td.properties[name].writeOnly);
    for (const name of names) {
        try {
            const output = await thing.readProperty(name);
            out.read[name] = await output.value();
        } catch (err) {
            out.read[name] = { error: message(err) };
        }
    }
    if (job.observe) {
        out.observed = [];
        const subscription = await thing.observeProperty(job.observe, async (data) => {
            out.observed.push(await data.value());
        });
        await new Promise((resolve) => setTimeout(resolve, job.for_ms));
        await subscription.stop();
    }
    process.stdout.write(JSON.stringify(out) + "\n");
    await servient.shutdown();
    process.exit(0);
}

main().catch((err) => {
    process.stderr.write(`wot_client: ${message(err)}\n`);
    process.exit(1);
});
