! A glue bead around a part (150 x 130 mm, 15 mm corner radius), the nozzle tilted 25 deg against the
! direction of travel and turned with it round each corner; z1 zones, a work object on the table.
MODULE GlueBead
    PERS tooldata tNozzle := [TRUE, [[0, 0, 150], [1, 0, 0, 0]], [1.5, [0, 0, 70], [1, 0, 0, 0], 0, 0, 0]];
    PERS wobjdata wPart := [FALSE, TRUE, "", [[420, -60, 300], [1, 0, 0, 0]], [[0, 0, 0], [1, 0, 0, 0]]];
    CONST robtarget pAbove := [[0, 0, 40], [0.0000000, 0.9762960, 0.0000000, 0.2164396], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pAboveEnd := [[0, 0, 40], [0.0000000, 0.9762960, 0.0000000, 0.2164396], [-1, 0, -3, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p1 := [[0, 0, 0], [0.0000000, 0.9762960, 0.0000000, 0.2164396], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p2 := [[150, 0, 0], [0.0000000, 0.9762960, 0.0000000, 0.2164396], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget c2 := [[160.6066, 4.3934, 0], [-0.0828279, 0.9019799, 0.3736123, 0.1999641], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p3 := [[165, 15, 0], [-0.1530459, 0.6903455, 0.6903455, 0.1530459], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p4 := [[165, 115, 0], [-0.1530459, 0.6903455, 0.6903455, 0.1530459], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget c4 := [[160.6066, 125.6066, 0], [-0.1999641, 0.3736123, 0.9019799, 0.0828279], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p5 := [[150, 130, 0], [-0.2164396, 0.0000000, 0.9762960, 0.0000000], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p6 := [[0, 130, 0], [-0.2164396, 0.0000000, 0.9762960, 0.0000000], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget c6 := [[-10.6066, 125.6066, 0], [-0.1999641, -0.3736123, 0.9019799, -0.0828279], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p7 := [[-15, 115, 0], [-0.1530459, -0.6903455, 0.6903455, -0.1530459], [0, -1, -1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p8 := [[-15, 15, 0], [-0.1530459, -0.6903455, 0.6903455, -0.1530459], [0, -1, -1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget c8 := [[-10.6066, 4.3934, 0], [-0.0828279, -0.9019799, 0.3736123, -0.1999641], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p9 := [[0, 0, 0], [-0.0000000, -0.9762960, 0.0000000, -0.2164396], [-1, 0, -3, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

    PROC main()
        MoveL pAbove, v500, fine, tNozzle \WObj:=wPart;
        MoveL p1, v200, fine, tNozzle \WObj:=wPart;
        MoveL p2, v200, z1, tNozzle \WObj:=wPart;
        MoveC c2, p3, v200, z1, tNozzle \WObj:=wPart;
        MoveL p4, v200, z1, tNozzle \WObj:=wPart;
        MoveC c4, p5, v200, z1, tNozzle \WObj:=wPart;
        MoveL p6, v200, z1, tNozzle \WObj:=wPart;
        MoveC c6, p7, v200, z1, tNozzle \WObj:=wPart;
        MoveL p8, v200, z1, tNozzle \WObj:=wPart;
        MoveC c8, p9, v200, fine, tNozzle \WObj:=wPart;
        MoveL pAboveEnd, v500, fine, tNozzle \WObj:=wPart;  ! axis 6 has turned a full turn round the part
    ENDPROC
ENDMODULE
