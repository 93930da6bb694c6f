-- tdb schema version 6 (postgresql); generated from tdb/schema.py

CREATE TABLE categories (
	code SMALLINT NOT NULL, 
	inclination SMALLINT NOT NULL, 
	feature SMALLINT NOT NULL, 
	orient_from SMALLINT, 
	orient_to SMALLINT, 
	flat_side SMALLINT NOT NULL, 
	description VARCHAR(200) NOT NULL, 
	PRIMARY KEY (code)
);

CREATE TABLE meta (
	key VARCHAR(64) NOT NULL, 
	value TEXT NOT NULL, 
	PRIMARY KEY (key)
);

CREATE TABLE versions (
	id SERIAL NOT NULL, 
	name VARCHAR(200) NOT NULL, 
	acquired DATE, 
	source TEXT, 
	crs TEXT, 
	params TEXT NOT NULL, 
	stats TEXT NOT NULL, 
	created VARCHAR(32) NOT NULL, 
	PRIMARY KEY (id), 
	UNIQUE (name)
);

CREATE TABLE buildings (
	version INTEGER NOT NULL, 
	bx INTEGER NOT NULL, 
	by INTEGER NOT NULL, 
	x FLOAT(53) NOT NULL, 
	y FLOAT(53) NOT NULL, 
	height FLOAT NOT NULL, 
	area FLOAT NOT NULL, 
	footprint BYTEA NOT NULL, 
	PRIMARY KEY (version, bx, by, x, y), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE c16 (
	version INTEGER NOT NULL, 
	xg INTEGER NOT NULL, 
	yg INTEGER NOT NULL, 
	c SMALLINT NOT NULL, 
	PRIMARY KEY (version, xg, yg), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE c2 (
	version INTEGER NOT NULL, 
	xg INTEGER NOT NULL, 
	yg INTEGER NOT NULL, 
	c SMALLINT NOT NULL, 
	PRIMARY KEY (version, xg, yg), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE c4 (
	version INTEGER NOT NULL, 
	xg INTEGER NOT NULL, 
	yg INTEGER NOT NULL, 
	c SMALLINT NOT NULL, 
	PRIMARY KEY (version, xg, yg), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE c8 (
	version INTEGER NOT NULL, 
	xg INTEGER NOT NULL, 
	yg INTEGER NOT NULL, 
	c SMALLINT NOT NULL, 
	PRIMARY KEY (version, xg, yg), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE coregistrations (
	before INTEGER NOT NULL, 
	after INTEGER NOT NULL, 
	setting VARCHAR(200) NOT NULL, 
	shift TEXT NOT NULL, 
	PRIMARY KEY (before, after, setting), 
	FOREIGN KEY(before) REFERENCES versions (id) ON DELETE CASCADE, 
	FOREIGN KEY(after) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE evidence_blocks (
	version INTEGER NOT NULL, 
	bx INTEGER NOT NULL, 
	by INTEGER NOT NULL, 
	data BYTEA NOT NULL, 
	PRIMARY KEY (version, bx, by), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE point_blocks (
	version INTEGER NOT NULL, 
	bx INTEGER NOT NULL, 
	by INTEGER NOT NULL, 
	data BYTEA NOT NULL, 
	PRIMARY KEY (version, bx, by), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE tdb (
	version INTEGER NOT NULL, 
	x FLOAT(53) NOT NULL, 
	y FLOAT(53) NOT NULL, 
	z FLOAT(53) NOT NULL, 
	n SMALLINT NOT NULL, 
	PRIMARY KEY (version, x, y), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE tile_blocks (
	version INTEGER NOT NULL, 
	level SMALLINT NOT NULL, 
	bx INTEGER NOT NULL, 
	by INTEGER NOT NULL, 
	codes BYTEA NOT NULL, 
	PRIMARY KEY (version, level, bx, by), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

CREATE TABLE trees (
	version INTEGER NOT NULL, 
	bx INTEGER NOT NULL, 
	by INTEGER NOT NULL, 
	x FLOAT(53) NOT NULL, 
	y FLOAT(53) NOT NULL, 
	height FLOAT NOT NULL, 
	crown_diameter FLOAT NOT NULL, 
	crown BYTEA NOT NULL, 
	PRIMARY KEY (version, bx, by, x, y), 
	FOREIGN KEY(version) REFERENCES versions (id) ON DELETE CASCADE
);

-- PostgreSQL 14 on; an older server keeps its default
ALTER TABLE "tile_blocks" ALTER COLUMN "codes" SET COMPRESSION lz4;
ALTER TABLE "point_blocks" ALTER COLUMN "data" SET COMPRESSION lz4;
ALTER TABLE "evidence_blocks" ALTER COLUMN "data" SET COMPRESSION lz4;
ALTER TABLE "trees" ALTER COLUMN "crown" SET COMPRESSION lz4;
ALTER TABLE "buildings" ALTER COLUMN "footprint" SET COMPRESSION lz4;
