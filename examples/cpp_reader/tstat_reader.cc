// Reads a TEMCO thermostat over Modbus TCP with the driver `mdl gen` generates from its MDL file.
//   tstat_reader HOST [PORT] [NEW_OCCUPIED_SETPOINT]
#include "temco_tstat.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>

int main(int argc, char **argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s HOST [PORT] [NEW_OCCUPIED_SETPOINT]\n", argv[0]);
        return 2;
    }
    const int port = argc > 2 ? std::atoi(argv[2]) : 502;
    modbus_t *ctx = modbus_new_tcp(argv[1], port);
    if (ctx == nullptr) {
        std::fprintf(stderr, "modbus_new_tcp: %s\n", modbus_strerror(errno));
        return 2;
    }
    modbus_set_slave(ctx, 1);
    if (modbus_connect(ctx) == -1) {
        std::fprintf(stderr, "cannot connect to %s:%d: %s\n", argv[1], port, modbus_strerror(errno));
        modbus_free(ctx);
        return 3;
    }

    int status = 0;
    TemcoTstat tstat(ctx);  // the driver does not own ctx
    double temperature = 0;
    if (tstat.read_room_temperature(&temperature) == -1) {
        std::fprintf(stderr, "room temperature: %s\n", modbus_strerror(errno));
        status = 3;
    } else {
        std::printf("room temperature: %.1f\n", temperature);
    }
    if (argc > 3 && tstat.write_occupied_setpoint(std::atof(argv[3])) == -1) {
        std::fprintf(stderr, "occupied setpoint: %s\n", modbus_strerror(errno));  // EINVAL outside 10..30
        status = 1;
    }
    TemcoTstatValues values;
    if (tstat.read_all(&values) == -1) {  // every readable value, in as few requests as possible
        std::fprintf(stderr, "read_all: %s\n", modbus_strerror(errno));
        status = 3;
    } else {
        std::printf("serial number: %u\n", static_cast<unsigned>(values.serial_number));
        std::printf("occupied setpoint: %.1f\n", values.occupied_setpoint);
        std::printf("fan speed: %u\n", static_cast<unsigned>(values.fan_speed));
    }
    modbus_close(ctx);
    modbus_free(ctx);
    return status;
}
