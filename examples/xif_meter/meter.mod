#filetype,Modbus_xif
#program_ID,9F00960528040F01
#version,2.1.4
#product_name,EM-340 Three-Phase Meter
#manufacturer,Example Metering
#description,Three-phase energy meter (Modbus RTU over RS-485)
Block Name,Block Index,Datapoint Name,Address,Native Type,IAP Type,Write Enable,Function Code,Word Order,Byte Order,Precision,Native Value 1,Native Value 2,Scaled Value 1,Scaled Value 2,Range Min,Range Max,Marker Value,Description
Identity,0,Model Code,11,UINT16,SNVT_count,-,FC04,,,,,,,,,,340,Model code (340 for the EM-340)
Identity,0,Firmware,12,UINT16,SNVT_count,-,FC04,,,,,,,,,,,Firmware version (BCD)
Phase,0,Voltage L1,0,UINT32,SNVT_volt,-,FC04,little,,1,0,10,0,1,,,,Line 1 to neutral voltage (V)
Phase,0,Current L1,2,SINT32,SNVT_amp,-,FC04,little,,3,0,1000,0,1,,,,Line 1 current (A)
Phase,1,Voltage L2,4,UINT32,SNVT_volt,-,FC04,little,,1,0,10,0,1,,,,Line 2 to neutral voltage (V)
Phase,1,Current L2,6,SINT32,SNVT_amp,-,FC04,little,,3,0,1000,0,1,,,,Line 2 current (A)
Phase,2,Voltage L3,8,UINT32,SNVT_volt,-,FC04,little,,1,0,10,0,1,,,,Line 3 to neutral voltage (V)
Phase,2,Current L3,10,SINT32,SNVT_amp,-,FC04,little,,3,0,1000,0,1,,,,Line 3 current (A)
Total,0,Power Factor,14,SINT16,SNVT_pwr_fact,-,FC04,,,3,0,1000,0,1,,,,Total power factor
Total,0,Frequency,15,UINT16,SNVT_freq_hz,-,FC04,,,2,0,100,0,1,,,,Grid frequency (Hz)
Total,0,Power,40,FLOAT32,SNVT_power_f,-,FC04,big,big,1,,,,,,,,Total active power (W)
Total,0,Energy Import,52,UINT32,SNVT_elec_kwh_l,-,FC04,little,,1,0,10,0,1,,,,Imported active energy (kWh)
Settings,0,CT Ratio,768,UINT16,SNVT_count,+,FC03,,,,,,,,1,5000,,Current transformer ratio
Settings,0,Demand Period,769,UINT16,SNVT_time_min,++,FC03,,,,,,,,1,60,,Demand integration period (min); the meter accepts FC16 only
Settings,0,Reset Energy,0,BIT,SNVT_switch,+,FC01,,,,,,,,,,,Write 1 to reset the energy counters
Status,0,Phase Sequence OK,0,BIT,SNVT_switch,-,FC02,,,,,,,,,,,Phase sequence is correct
