! Deburring along a 240 mm edge: the tool turned 90 deg about the vertical, tilted 35 deg and rolled from -20 to +25 deg along the edge, z5
! zones (pzone_ori / zone_ori from ABB's table blend the orientation too), a custom zonedata at the turn.
MODULE Deburr
    PERS tooldata tSpindle := [TRUE, [[0, 0, 180], [1, 0, 0, 0]], [3, [0, 0, 80], [1, 0, 0, 0], 0.01, 0.01, 0.005]];
    CONST zonedata zEdge := [FALSE, 3, 6, 6, 2, 6, 2];
    CONST robtarget pIn := [[480, -150, 420], [-0.0922960, 0.7010574, 0.6272114, 0.3265056], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget e1 := [[480, -120, 380], [-0.0922960, 0.7010574, 0.6272114, 0.3265056], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget e2 := [[480, -40, 380], [-0.1530459, 0.6903455, 0.6532815, 0.2705981], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget e3 := [[480, 40, 380], [-0.2126311, 0.6743797, 0.6743797, 0.2126311], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget e4 := [[480, 120, 380], [-0.2988362, 0.6408564, 0.6963642, 0.1227878], [-1, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget e5 := [[520, 140, 380], [-0.3535534, 0.6123724, 0.7044160, 0.0616284], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pOut := [[520, 140, 430], [-0.3535534, 0.6123724, 0.7044160, 0.0616284], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

    PROC main()
        MoveL pIn, v500, fine, tSpindle;
        MoveL e1, v200, fine, tSpindle;
        MoveL e2, v100, z5, tSpindle;
        MoveL e3, v100, z5, tSpindle;
        MoveL e4, v100, zEdge, tSpindle;
        MoveL e5, v100, fine, tSpindle;
        MoveL pOut, v500, fine, tSpindle;
    ENDPROC
ENDMODULE
