/* Writes of a generated C driver (copied when it writes anything). */

/* count registers (or one coil) of a table from start: 0, or -1 with errno */
static int mdl_write_table(modbus_t *ctx, enum mdl_table table, int start, int count, const uint16_t *src) {
    int rc = -1;
    mdl_drop_stale_bytes(ctx);
    if (table == MDL_COIL) {
        rc = modbus_write_bit(ctx, start, src[0] != 0U ? 1 : 0);
    } else if (count == 1) {
        rc = modbus_write_register(ctx, start, src[0]);
    } else {
        rc = modbus_write_registers(ctx, start, count, src);
    }
    if (rc == -1) {
        return -1;
    }
    return mdl_check_reply_ended(ctx);
}
