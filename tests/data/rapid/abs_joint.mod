! MoveAbsJ: the cycle starts from a home jointtarget, picks above a conveyor and places on a table (MoveJ
! between approach points, fine points at the pick and the place), and returns by MoveAbsJ to an inline
! jointtarget (axes in degrees, external axes 9E9 = none).
MODULE AbsJoint
    PERS tooldata tGripper := [TRUE, [[0, 0, 120], [1, 0, 0, 0]], [4, [0, 0, 60], [1, 0, 0, 0], 0.02, 0.02, 0.01]];
    CONST jointtarget jHome := [[0, 10, 5, 0, 75, 180], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPickAbove := [[350, -300, 400], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPick := [[350, -300, 300], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPlaceAbove := [[500, 150, 350], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [0, -1, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPlace := [[500, 150, 250], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [0, -1, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

    PROC main()
        MoveAbsJ jHome\NoEOffs, v1000, fine, tGripper;
        MoveJ pPickAbove, v2000, z20, tGripper;
        MoveL pPick, v500, fine, tGripper;
        MoveL pPickAbove, v1000, z20, tGripper;
        MoveJ pPlaceAbove, v2000, z20, tGripper;
        MoveL pPlace, v500, fine, tGripper;
        MoveL pPlaceAbove, v1000, fine, tGripper;
        MoveAbsJ [[-20, 15, 10, 10, 65, 150], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v2000, fine, tGripper \WObj:=wobj0;
    ENDPROC
ENDMODULE
