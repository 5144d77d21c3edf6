! Test module for the RAPID import: tool and work-object frames, MoveC, MoveJ, speeds and zones.
module FrameTest
    ! TCP 100 mm along the flange z, tilted 45 deg about y; 2 kg at 50 mm, principal axes turned 90 deg about z
    PERS tooldata tPen := [TRUE, [[0, 0, 100], [0.9238795325, 0, 0.3826834324, 0]],
        [2, [0, 0, 50], [0.7071067812, 0, 0, 0.7071067812], 0.01, 0.02, 0.03]];
    PERS wobjdata wTable := [FALSE, TRUE, "",
        [[400, 100, 300], [0.7071067812, 0, 0, 0.7071067812]],   ! user frame: turned 90 deg about z
        [[10, 0, 0], [1, 0, 0, 0]]];                              ! object frame: 10 mm along user x
    CONST robtarget p10 := [[100, 0, 200], [0, 1, 0, 0], [0, -1, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pCir := [[150, 50, 200], [0, 1, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget p20 := [[100, 100, 200], [0, 1, 0, 0], [0, -1, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    VAR speeddata vSlow := [250, 500, 5000, 1000];
    CONST zonedata zTight := [FALSE, 3, 4.5, 4.5, 0.45, 4.5, 0.45];

    PROC main()
        movel p10, v500, fine, tPen\WObj:=wTable;
        MoveC pCir, p20, vSlow, z5, tPen \WObj:=wTable;   ! half circle, radius 50 mm
        MOVEL Offs(p20, 0, 100, 0),
              v1000 \V:=800, zTight, tPen \WObj:=wTable;
        MoveJ [[0, 200, 200], [0, 1, 0, 0], [0, -1, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],
              v200 \T:=0.5, z10 \Z:=7, tPen \WObj:=wTable;
        SingArea \Wrist;
        TPWrite "done";
        SetDO doGrip, 1;
        WaitTime 0.5;
    ENDPROC
ENDMODULE
