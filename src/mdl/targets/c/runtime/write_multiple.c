/* Writes of a generated C driver's functions that say write_multiple (copied when one writes):
 * function 15 for a coil and 16 for registers, even for one, for devices that refuse 5 and 6. */

/* count registers (or one coil) of a table from start: 0, or -1 with errno */
static int mdl_write_multiple(modbus_t *ctx, enum mdl_table table, int start, int count, const uint16_t *src) {
    int rc = -1;
    mdl_drop_stale_bytes(ctx);
    if (table == MDL_COIL) {
        const uint8_t bit = (uint8_t)(src[0] != 0U ? 1 : 0);
        rc = modbus_write_bits(ctx, start, 1, &bit);
    } else {
        rc = modbus_write_registers(ctx, start, count, src);
    }
    if (rc == -1) {
        return -1;
    }
    return mdl_check_reply_ended(ctx);
}
