/* Function 22 of a generated C driver (copied when a function with bits says write_function_code 22). */

/* Mask Write Register: the device sets the register to (current & and_mask) | (or_mask & ~and_mask),
 * so only the bits outside and_mask change: 0, or -1 with errno */
static int mdl_mask_write(modbus_t *ctx, int address, uint16_t and_mask, uint16_t or_mask) {
    mdl_drop_stale_bytes(ctx);
    if (modbus_mask_write_register(ctx, address, and_mask, or_mask) == -1) {
        return -1;
    }
    return mdl_check_reply_ended(ctx);
}
