/* Reads of a generated C driver (copied when it reads anything). */

/* count registers (or bits, as 0 and 1) of a table from start into dest: 0, or -1 with errno */
static int mdl_read_table(modbus_t *ctx, enum mdl_table table, int start, int count, uint16_t *dest) {
    int rc = -1;
    mdl_drop_stale_bytes(ctx);
    if (table == MDL_HOLDING) {
        rc = modbus_read_registers(ctx, start, count, dest);
    } else if (table == MDL_INPUT) {
        rc = modbus_read_input_registers(ctx, start, count, dest);
    } else {
        uint8_t bits[MODBUS_MAX_READ_BITS];
        int i;
        if (count < 1 || count > MODBUS_MAX_READ_BITS) {
            errno = EINVAL;
            return -1;
        }
        rc = table == MDL_COIL ? modbus_read_bits(ctx, start, count, bits)
                               : modbus_read_input_bits(ctx, start, count, bits);
        if (rc == count) {
            for (i = 0; i < count; ++i) {
                dest[i] = (uint16_t)(bits[i] != 0U ? 1U : 0U);
            }
        }
    }
    if (rc == -1) {
        return -1;
    }
    if (rc != count) {
        errno = EMBBADDATA;
        return -1;
    }
    return mdl_check_reply_ended(ctx);
}
