! Machine tending: load a part into a machine, wait for the cycle, unload, three times; procedures
! without parameters, a FOR loop over the parts (Offs with the loop variable), WaitTime, ConfL.
MODULE Tending
    PERS tooldata tGrip := [TRUE, [[0, 0, 100], [1, 0, 0, 0]], [2, [0, 0, 50], [1, 0, 0, 0], 0, 0, 0]];
    CONST num pitch := 40;
    CONST robtarget pHome := [[450, 0, 500], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [0, 0, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pTray := [[380, -200, 300], [0.0000000, 1.0000000, 0.0000000, 0.0000000], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pChuck := [[600, 100, 350], [0.0000000, 0.7071068, 0.7071068, 0.0000000], [0, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];

    PROC main()
        MoveL pHome, v1000, fine, tGrip;
        ConfL \On;
        FOR i FROM 0 TO 2 DO
            MoveL Offs(pTray, i * pitch, 0, 80), v1000, z10, tGrip;
            MoveL Offs(pTray, i * pitch, 0, 0), v300, fine, tGrip;
            WaitTime 0.2;
            MoveL Offs(pTray, i * pitch, 0, 80), v1000, z10, tGrip;
            LoadMachine;
        ENDFOR
        ConfL \Off;  ! axis 4 comes back in another quadrant: take the branch the path arrives on
        MoveL pHome, v1000, fine, tGrip \Conc;
    ENDPROC

    PROC LoadMachine()
        MoveL Offs(pChuck, -100, 0, 0), v1000, z10, tGrip;
        MoveL pChuck, v200, fine, tGrip;
        WaitTime 0.5;
        MoveL Offs(pChuck, -100, 0, 0), v1000, z10, tGrip;
    ENDPROC
ENDMODULE
