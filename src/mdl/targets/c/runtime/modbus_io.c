/* Requests of a generated C driver (mdl.targets.c; docs/c-api.md). Copied into every driver.
 * Needs <errno.h>, <stdint.h> and <modbus.h>. */

/* the four tables of a Modbus device */
enum mdl_table { MDL_COIL, MDL_DISCRETE, MDL_HOLDING, MDL_INPUT };

/* Bytes waiting before a request answer nothing it asks (a reply that came after its call had timed
 * out, the rest of a reply that framed less than it sent): they are dropped, or libmodbus would
 * read them as the start of the reply. */
static void mdl_drop_stale_bytes(modbus_t *ctx) {
    (void)modbus_flush(ctx);
}

/* libmodbus reads a TCP reply as far as its function code and byte count say, not as far as its
 * MBAP length says. Bytes already waiting after the reply mean it framed less than it sent (or came
 * with something unasked): it is not trusted, -1 with EMBBADDATA, and the bytes are dropped. */
static int mdl_check_reply_ended(modbus_t *ctx) {
    if (modbus_flush(ctx) > 0) {
        errno = EMBBADDATA;
        return -1;
    }
    return 0;
}
