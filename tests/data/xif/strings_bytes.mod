#filetype,Modbus_xif
#program_ID,9F-FF-FF-05-28-04-DB-02
#product_name,Text and byte test device
Datapoint Name,Native Type,ASCII Length,Address,Modicon,Function Code,Byte Order,Word Order,Write Enable,Description,IAP Type
Name,CHAR8_2,8,40101,Y,,big,,+,"Device name, 8 characters",SNVT_str_asc
Name Swapped,CHAR8_2,5,110,N,FC03,little,,-,"Five characters, bytes swapped",SNVT_str_asc
Tag,CHAR8,4,120,N,FC03,,,-,One character in each register,SNVT_str_asc
Low Byte,UINT8,,140,N,FC03,,,+,Low byte of register 140,SNVT_count
High Byte,UINT8,,140,N,FC03,little,,+,High byte of register 140,SNVT_count
Signed Byte,SINT8,,141,N,FC03,,,-,,SNVT_count_inc
Counter,UINT64,,150,N,FC04,big,little,-,"64-bit counter, low word first",SNVT_count_f
Double,FLOAT64,,160,N,FC04,,big,-,"""Quoted"" 64-bit float, with a comma",SNVT_count_f
Signed Total,SINT32,,170,N,FC03,little,little,+,Little-endian 32-bit,SNVT_count_f
