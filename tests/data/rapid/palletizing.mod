! Palletizing: boxes from a conveyor onto a pallet, the second one turned 90 deg; joint moves between
! the approach points, fine points at the pick and the place, a short grip wait.
MODULE Palletizing
    PERS tooldata tGripper := [TRUE, [[0, 0, 120], [1, 0, 0, 0]], [4, [0, 0, 60], [1, 0, 0, 0], 0.02, 0.02, 0.01]];
    CONST robtarget pHome := [[450, 0, 550], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [0, 0, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPick := [[350, -300, 300], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPlace1 := [[500, 150, 250], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [0, -1, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPlace2 := [[500, 300, 250], [0.0000000, 0.7071068, 0.7071068, 0.0000000], [0, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

    PROC main()
        MoveL pHome, v1000, fine, tGripper;
        MoveJ Offs(pPick, 0, 0, 100), v2000, z20, tGripper;
        MoveL pPick, v500, fine, tGripper;
        WaitTime 0.1;
        MoveL Offs(pPick, 0, 0, 100), v1000, z20, tGripper;
        MoveJ Offs(pPlace1, 0, 0, 100), v2000, z20, tGripper;
        MoveL pPlace1, v500, fine, tGripper;
        MoveL Offs(pPlace1, 0, 0, 100), v1000, z20, tGripper;
        MoveJ Offs(pPick, 0, 0, 100), v2000, z20, tGripper;
        MoveL pPick, v500, fine, tGripper;
        MoveL Offs(pPick, 0, 0, 100), v1000, z20, tGripper;
        MoveJ Offs(pPlace2, 0, 0, 100), v2000, z20, tGripper;
        MoveL pPlace2, v500, fine, tGripper;
        MoveL Offs(pPlace2, 0, 0, 100), v1000, fine, tGripper;
    ENDPROC
ENDMODULE
