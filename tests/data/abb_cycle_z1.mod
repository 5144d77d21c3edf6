%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
! The ABB standard cycle (cycle-time definition): 25 mm up, 305 mm across, 25 mm down, and back,
! with a 1 kg load, tool pointing down, around (0.5, 0, 0.5) m in front of an IRB140.
! Corners at the top: z1; the pick and place points at the bottom are fine points.
MODULE AbbCycleZ1
    PERS tooldata tGripper := [TRUE, [[0, 0, 0], [1, 0, 0, 0]],
                               [1, [0, 0, 0], [1, 0, 0, 0], 0, 0, 0]];   ! 1 kg at the flange
    PERS wobjdata wCycle := [FALSE, TRUE, "", [[500, 0, 500], [1, 0, 0, 0]], [[0, 0, 0], [1, 0, 0, 0]]];
    CONST robtarget pPick := [[0, -152.5, 0], [0, 1, 0, 0], [-1, 0, 1, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST robtarget pPlace := [[0, 152.5, 0], [0, 1, 0, 0], [0, 0, 2, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];
    CONST num hUp := 25;

    PROC main()
        MoveL pPick, v1000, fine, tGripper \WObj:=wCycle;
        MoveL Offs(pPick, 0, 0, hUp), v1000, z1, tGripper \WObj:=wCycle;
        MoveL Offs(pPlace, 0, 0, hUp), v1000, z1, tGripper \WObj:=wCycle;
        MoveL pPlace, v1000, fine, tGripper \WObj:=wCycle;
        MoveL Offs(pPlace, 0, 0, hUp), v1000, z1, tGripper \WObj:=wCycle;
        MoveL Offs(pPick, 0, 0, hUp), v1000, z1, tGripper \WObj:=wCycle;
        MoveL pPick, v1000, fine, tGripper \WObj:=wCycle;
    ENDPROC
ENDMODULE
