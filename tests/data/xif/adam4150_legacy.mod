#filetype,Modbus_xif
#program_ID,9F0096052804DB00
#manufacturer,Advantech
#description,ADAM-4150 digital I/O module (7 DI / 8 DO)
Point Name,Presentation type,Modbus datatype,Function Code,Address,Direction,A',B',C',Range Min,Range Max,Block Name,inFeedback,Marker value,Description (optional)
DI_0,SNVT_count,BIT,FC01,0,R,1,0,0,0,1,DI,FALSE,"",Digital input 0
DI_1,SNVT_count,BIT,FC01,1,R,1,0,0,0,1,DI,FALSE,"",Digital input 1
DI_2,SNVT_count,BIT,FC01,2,R,1,0,0,0,1,DI,FALSE,"",Digital input 2
DI_3,SNVT_count,BIT,FC01,3,R,1,0,0,0,1,DI,FALSE,"",Digital input 3
DI_4,SNVT_count,BIT,FC01,4,R,1,0,0,0,1,DI,FALSE,"",Digital input 4
DI_5,SNVT_count,BIT,FC01,5,R,1,0,0,0,1,DI,FALSE,"",Digital input 5
DI_6,SNVT_count,BIT,FC01,6,R,1,0,0,0,1,DI,FALSE,"",Digital input 6
DO_0,SNVT_count,BIT,FC01,16,RW,1,0,0,0,1,DO,FALSE,"",Digital output 0
DO_1,SNVT_count,BIT,FC01,17,RW,1,0,0,0,1,DO,FALSE,"",Digital output 1
DO_2,SNVT_count,BIT,FC01,18,RW,1,0,0,0,1,DO,FALSE,"",Digital output 2
DO_3,SNVT_count,BIT,FC01,19,RW,1,0,0,0,1,DO,FALSE,"",Digital output 3
DO_4,SNVT_count,BIT,FC01,20,RW,1,0,0,0,1,DO,FALSE,"",Digital output 4
DO_5,SNVT_count,BIT,FC01,21,RW,1,0,0,0,1,DO,FALSE,"",Digital output 5
DO_6,SNVT_count,BIT,FC01,22,RW,1,0,0,0,1,DO,FALSE,"",Digital output 6
DO_7,SNVT_count,BIT,FC01,23,RW,1,0,0,0,1,DO,FALSE,"",Digital output 7
Counter_0,SNVT_count,UINT32,FC04,0,R,1,0,0,"","",Counter,FALSE,"",Counter 0 (low word first)
Temp_Board,SNVT_temp_p,SINT16,FC04,100,R,5,-1,-400,"","",Dev,FALSE,"",Board temperature: (raw - 400) / 2 degC
ModuleName-1,SNVT_count,UINT16,FC04,210,R,1,0,0,"","",Dev,FALSE,16720,Module name 0x4150
