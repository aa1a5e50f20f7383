# cell_st.py -- the Structured Text half of the LD cell's project (generate.py): the program's
# declarations (its body is the ladder) and the two function blocks its first and last rungs call:
# CellInputs (the panel's defaults, the robot's image, the operator's requests, the speeds) and
# CellOutputs (the request to the robot, PLC_OUT and the alarms), the same statements as
# config/sets/plc-robot-st/main.st's "read inputs" and "write outputs" parts; and the configuration.

PROGRAM = """
PROGRAM PickAndPlace
VAR CONSTANT
  HOME : AXES := [0.0, 0.0, 0.0, 0.0, 1.5708, 0.0];
  PICK_ABOVE : AXES := [0.3948, 0.5181, 0.3196, 0.0, 0.7332, 0.3948];
  PICK : AXES := [0.60, 0.25, 0.30, 3.14159265, 0.0, 3.14159265];
  PLACE_ABOVE : AXES := [-0.3948, 0.5181, 0.3196, 0.0, 0.7332, -0.3948];
  PLACE : AXES := [0.60, -0.25, 0.30, 3.14159265, 0.0, 3.14159265];
  ACCEL : LREAL := 0.5;
  DWELL : TIME := T#200ms;
  STEP_IDLE : DINT := 0;
  STEP_HOME : DINT := 1;
  STEP_ABOVE_PICK : DINT := 2;
  STEP_PICK_DOWN : DINT := 3;
  STEP_PICK_UP : DINT := 4;
  STEP_ABOVE_PLACE : DINT := 5;
  STEP_PLACE_DOWN : DINT := 6;
  STEP_PLACE_UP : DINT := 7;
  STEP_HOME_AGAIN : DINT := 8;
  POWER_REMOVED : DINT := 1010;
  CYCLE_REPEAT : INT := 1;
  NO_ERROR : DINT := 0;
  ONE : UDINT := 1;
END_VAR
VAR
  Robot : AXES_GROUP_REF;
  Inputs : CellInputs;
  Outputs : CellOutputs;
  Power : MC_Power;
  StopRobot : MC_Stop;
  ResetRobot : MC_Reset;
  GroupError : MC_GroupReadError;
  MoveJ_Home, MoveJ_AbovePick, MoveJ_AbovePlace, MoveJ_HomeAgain : MC_MoveAbsolute;
  MoveL_PickDown, MoveL_PickUp, MoveL_PlaceDown, MoveL_PlaceUp : MC_MoveLinear;
  StartEdge, ResetDone : R_TRIG;
  PickDwell, PlaceDwell : TON;
  Step : DINT := STEP_IDLE;
  CycleDone : BOOL;
  ErrorLatched : BOOL;
  ErrorCode : DINT;
  Cycles : UDINT;
  PowerOn : BOOL;
  (* the rungs' own bits and values *)
  Busy, Idle, InStep, NoGroupError, Again : BOOL;
  NextStep : DINT;
  NextCycles : UDINT;
END_VAR
END_PROGRAM
"""

INPUTS = """
FUNCTION_BLOCK CellInputs
VAR_IN_OUT Robot : AXES_GROUP_REF; END_VAR
VAR_OUTPUT
  First : BOOL;        (* the first scan: a Start already held then is no edge *)
  StopReq, Enable, CommLost, StartReq, ResetReq : BOOL;
  vJ, vL : LREAL;      (* MoveJ and MoveL speeds with the Override *)
  Requested : UDINT;   (* the request's nSeq before the blocks ran *)
  PickUp, PlaceUp : AXES;
END_VAR
VAR CONSTANT
  PICK : AXES := [0.60, 0.25, 0.30, 3.14159265, 0.0, 3.14159265];
  PLACE : AXES := [0.60, -0.25, 0.30, 3.14159265, 0.0, 3.14159265];
  LIFT : LREAL := 0.1;
  JOINT_SPEED : LREAL := 0.5;
  LINEAR_SPEED : LREAL := 0.25;
  OVERRIDE_DEFAULT : LREAL := 1.0;
  AUTO_ENABLE : BOOL := FALSE;
  MIN_OVERRIDE : LREAL := 0.01;
END_VAR
VAR FirstScan : BOOL := TRUE; END_VAR
VAR_TEMP Ov : LREAL; i : INT; END_VAR
First := FirstScan;
IF FirstScan THEN
  IF PLC_ROBOT.PLC_IN.Override = 0.0 THEN
    PLC_ROBOT.PLC_IN.Override := OVERRIDE_DEFAULT;
  END_IF;
  IF AUTO_ENABLE THEN
    PLC_ROBOT.PLC_IN.Enable := 1;
  END_IF;
END_IF;
PickUp := PICK;
PickUp[2] := PickUp[2] + LIFT;
PlaceUp := PLACE;
PlaceUp[2] := PlaceUp[2] + LIFT;
Robot.State.MotionDone := PLC_ROBOT.ROBOT_MODULE_STATE.MotionDone;
Robot.State.Busy := PLC_ROBOT.ROBOT_MODULE_STATE.Busy;
Robot.State.eState := PLC_ROBOT.ROBOT_MODULE_STATE.eState;
Robot.State.Powered := PLC_ROBOT.ROBOT_MODULE_STATE.Powered;
Robot.State.Error := PLC_ROBOT.ROBOT_MODULE_STATE.Error;
Robot.State.ErrorID := PLC_ROBOT.ROBOT_MODULE_STATE.ErrorID;
Robot.State.nAckSeq := PLC_ROBOT.ROBOT_MODULE_STATE.nAckSeq;
Robot.State.dCurJoint := PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint;
Robot.State.dCmdJoint := PLC_ROBOT.ROBOT_MODULE_STATE.dCmdJoint;
Robot.Service.eOpCode := PLC_ROBOT.ROBOT_MODULE_SERVICE.eOpCode;
Robot.Service.nSeq := PLC_ROBOT.ROBOT_MODULE_SERVICE.nSeq;
Robot.Service.t_speed := PLC_ROBOT.ROBOT_MODULE_SERVICE.t_speed;
Robot.Service.t_accel := PLC_ROBOT.ROBOT_MODULE_SERVICE.t_accel;
Robot.Service.dTarget := PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget;
Requested := Robot.Service.nSeq;
CommLost := FALSE;
FOR i := 0 TO 7 DO
  CommLost := CommLost OR PLC_ROBOT.IO_STATUS.comm_lost[i] <> 0;
END_FOR;
StopReq := PLC_ROBOT.I1 <> 0 OR PLC_ROBOT.PLC_IN.Stop <> 0;
Enable := PLC_ROBOT.PLC_IN.Enable <> 0;
StartReq := PLC_ROBOT.I0 <> 0 OR PLC_ROBOT.PLC_IN.Start <> 0;
ResetReq := PLC_ROBOT.PLC_IN.Reset <> 0;
Ov := PLC_ROBOT.PLC_IN.Override;
IF NOT (Ov >= MIN_OVERRIDE) THEN  (* also NaN *)
  Ov := MIN_OVERRIDE;
END_IF;
IF Ov > 1.0 THEN
  Ov := 1.0;
END_IF;
vJ := JOINT_SPEED * Ov;
vL := LINEAR_SPEED * Ov;
FirstScan := FALSE;
END_FUNCTION_BLOCK
"""

OUTPUTS = """
FUNCTION_BLOCK CellOutputs
VAR_IN_OUT Robot : AXES_GROUP_REF; END_VAR
VAR_INPUT
  Step : DINT;
  CycleDone, ErrorLatched : BOOL;
  ErrorCode, GroupErrorID : DINT;
  Powered, Enable, PowerOn, CommLost : BOOL;
  Cycles, Requested : UDINT;
END_VAR
VAR CONSTANT
  COMM_LOST : DINT := 8;
  WAITS_FOR_RESET : DINT := 1000;
  ALARM_IDS : ARRAY[0..13] OF DINT := [1, 2, 3, 4, 5, 6, 7, 8, 1000, 1001, 1002, 1003, 1004, 1010];
END_VAR
VAR
  CauseRaised : DINT;
  WaitingRaised : BOOL;
  AlarmsKnown : BOOL;
  LastStep : DINT;
END_VAR
VAR_TEMP
  OutError, Waiting : BOOL;
  OutErrorID, Error, Cause : DINT;
  i : INT;
  Detail : STRING[48];
END_VAR
(* the request, whole, when a block wrote one; the PLC points *)
IF Robot.Service.nSeq <> Requested THEN
  PLC_ROBOT.ROBOT_MODULE_SERVICE.eOpCode := Robot.Service.eOpCode;
  PLC_ROBOT.ROBOT_MODULE_SERVICE.t_speed := Robot.Service.t_speed;
  PLC_ROBOT.ROBOT_MODULE_SERVICE.t_accel := Robot.Service.t_accel;
  PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget := Robot.Service.dTarget;
  PLC_ROBOT.ROBOT_MODULE_SERVICE.nSeq := Robot.Service.nSeq;
END_IF;
OutError := ErrorLatched OR GroupErrorID <> 0;
IF ErrorLatched THEN
  OutErrorID := ErrorCode;
ELSE
  OutErrorID := GroupErrorID;
END_IF;
PLC_ROBOT.O0 := BOOL_TO_INT(Robot.State.MotionDone <> 0);
PLC_ROBOT.PLC_OUT.Running := BOOL_TO_INT(Step <> 0);
PLC_ROBOT.PLC_OUT.Done := BOOL_TO_INT(CycleDone);
PLC_ROBOT.PLC_OUT.Error := BOOL_TO_INT(OutError);
PLC_ROBOT.PLC_OUT.Powered := BOOL_TO_INT(Powered);
PLC_ROBOT.PLC_OUT.WaitingForDrives := BOOL_TO_INT(Enable AND NOT PowerOn);
PLC_ROBOT.PLC_OUT.Step := Step;
PLC_ROBOT.PLC_OUT.ErrorID := OutErrorID;
PLC_ROBOT.PLC_OUT.Cycles := Cycles;

(* the alarm of the ErrorID PLC_OUT shows, as main.st raises it *)
IF Step <> 0 THEN
  LastStep := Step;
ELSIF NOT OutError THEN
  LastStep := 0;
END_IF;
Error := 0;
IF OutError THEN
  Error := OutErrorID;
END_IF;
Cause := Error;
IF Error = COMM_LOST AND NOT CommLost THEN
  Cause := 0;
END_IF;
Waiting := Error <> 0 AND Cause = 0;
IF NOT AlarmsKnown THEN
  FOR i := 0 TO 13 DO
    IF ALARM_IDS[i] <> Cause AND NOT (Waiting AND ALARM_IDS[i] = WAITS_FOR_RESET) THEN
      ClearAlarm(DINT_TO_UDINT(ALARM_IDS[i]));
    END_IF;
  END_FOR;
  CauseRaised := 0;
  WaitingRaised := FALSE;
  AlarmsKnown := TRUE;
END_IF;
IF Cause <> CauseRaised THEN
  IF CauseRaised > 0 THEN
    ClearAlarm(DINT_TO_UDINT(CauseRaised));
  END_IF;
  IF Cause > 0 THEN
    Detail := '';
    IF LastStep <> 0 THEN
      Detail := CONCAT('PLC stopped in step ', DINT_TO_STRING(LastStep), ' of the cycle');
    END_IF;
    RaiseAlarm(id := DINT_TO_UDINT(Cause), detail := Detail, value := DINT_TO_LREAL(Cause));
  END_IF;
  CauseRaised := Cause;
END_IF;
IF Waiting <> WaitingRaised THEN
  IF Waiting THEN
    RaiseAlarm(id := DINT_TO_UDINT(WAITS_FOR_RESET), detail := '', value := DINT_TO_LREAL(Error));
  ELSE
    ClearAlarm(DINT_TO_UDINT(WAITS_FOR_RESET));
  END_IF;
  WaitingRaised := Waiting;
END_IF;
END_FUNCTION_BLOCK
"""

CONFIGURATION = """
CONFIGURATION Cell
  RESOURCE Controller ON irpd
    TASK Plc (INTERVAL := T#10ms, PRIORITY := 3);
    PROGRAM main WITH Plc : PickAndPlace;
  END_RESOURCE
END_CONFIGURATION
"""
